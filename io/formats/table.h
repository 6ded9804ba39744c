// The sample table of docs/formats.md: readings of a point gonioreflectometer, one per CSV row:
// theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,r,g,b  (or one value column y; or no values).
// Angles in the sample frame: theta from N, phi from U toward N x U; i = light, o = view.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "models/local_dir.h"
#include "models/material.h"

namespace aniso {

struct SampleRow {
  double theta_i = 0, phi_i = 0, theta_o = 0, phi_o = 0;
  std::array<double, 3> value{0, 0, 0};
  double s = 0;         // optional topology value (fiber model)
  double u = 0, v = 0;  // optional: where on the sample (texture coordinates, glTF convention)
};

struct SampleTable {
  enum class Values { kNone, kGrey, kRGB };
  Values values = Values::kNone;
  bool has_s = false;
  bool has_uv = false;  // columns u, v: the spot each reading was taken at
  std::vector<SampleRow> rows;
};

SampleTable read_table(const std::string& path);
// Writes the table with values (grey tables get a y column); atomic; refuses non-finite values.
void write_table(const std::string& path, const SampleTable& t);

LocalDir dir_from_angles(double theta_deg, double phi_deg);

// Fills every row's r,g,b with the material's reflectance (an `s` column gives the fiber
// model's topology per row; u, v columns the material's maps at the row's spot).
void evaluate_table(const Material& m, SampleTable* t);

// How far a material is from a table's readings: the relative RMS (sqrt of sum |model - reading|^2
// over sum |reading|^2, every channel), the same per viewer angle theta_o (degrees, to 0.01), and
// the median reading's own relative error (green), which the sum of squares, led by a sharp peak,
// hides.
struct TableMisfit {
  double relative_rms = 0, median_relative = -1;
  std::vector<std::pair<double, double>> relative_rms_by_theta_o;
};
TableMisfit table_misfit(const Material& m, const SampleTable& readings);
// The same measures for `model`, a table of the same rows (directions) holding another model's
// values (another tool's fit evaluated at the readings' directions).
TableMisfit table_misfit(const SampleTable& model, const SampleTable& readings);

}  // namespace aniso
