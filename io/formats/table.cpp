#include "io/formats/table.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "core/angles.h"
#include "core/error.h"
#include "core/text.h"
#include "io/files/files.h"
#include "models/evaluate.h"
#include "models/material_maps.h"

namespace aniso {

namespace {

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream ss(line);
  while (std::getline(ss, cell, ',')) {
    while (!cell.empty() && (cell.back() == '\r' || cell.back() == ' ')) cell.pop_back();
    while (!cell.empty() && cell.front() == ' ') cell.erase(cell.begin());
    out.push_back(cell);
  }
  return out;
}

}  // namespace

LocalDir dir_from_angles(double theta_deg, double phi_deg) {
  const double t = deg_to_rad(theta_deg), p = deg_to_rad(phi_deg);
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

SampleTable read_table(const std::string& path) {
  std::istringstream f(read_text_file(path));  // a regular file of bounded size
  std::string line;
  if (!std::getline(f, line)) throw Error(path + ": empty file (expected a header line)");
  if (line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 byte-order mark
  const auto head = split_csv(line);
  constexpr int kColumns = 11;
  int col[kColumns];
  const char* names[kColumns] = {"theta_i_deg", "phi_i_deg", "theta_o_deg", "phi_o_deg", "r", "g",
                                 "b",           "y",         "s",           "u",         "v"};
  for (int k = 0; k < kColumns; ++k) {
    col[k] = -1;
    for (size_t c = 0; c < head.size(); ++c)
      if (head[c] == names[k]) col[k] = static_cast<int>(c);
  }
  for (int k = 0; k < 4; ++k)
    if (col[k] < 0) throw Error(path + ": header: missing column '" + names[k] + "'");
  const std::vector<std::string> known_names(names, names + kColumns);
  for (size_t c = 0; c < head.size(); ++c) {
    bool known = false;
    for (int k = 0; k < kColumns; ++k) known |= head[c] == names[k];
    if (!known)
      throw Error(path + ": header: unknown column '" + head[c] + "'" +
                  did_you_mean(head[c], known_names));
    for (size_t d = 0; d < c; ++d)
      if (head[d] == head[c])
        throw Error(path + ": header: column '" + head[c] + "' appears twice");
  }
  SampleTable t;
  const bool rgb = col[4] >= 0 || col[5] >= 0 || col[6] >= 0;
  if (rgb && (col[4] < 0 || col[5] < 0 || col[6] < 0))
    throw Error(path + ": header: r, g and b go together");
  if (rgb && col[7] >= 0) throw Error(path + ": header: give either r,g,b or y, not both");
  t.values = rgb ? SampleTable::Values::kRGB
                 : (col[7] >= 0 ? SampleTable::Values::kGrey : SampleTable::Values::kNone);
  t.has_s = col[8] >= 0;
  if ((col[9] >= 0) != (col[10] >= 0)) throw Error(path + ": header: u and v go together");
  t.has_uv = col[9] >= 0;
  int lineno = 1;
  while (std::getline(f, line)) {
    ++lineno;
    if (line.find_first_not_of(" \r\t") == std::string::npos) continue;
    const auto cells = split_csv(line);
    auto get = [&](int k, double lo, double hi) {
      if (col[k] >= static_cast<int>(cells.size()))
        throw Error(path + ":" + std::to_string(lineno) + ": missing value for '" + names[k] + "'");
      double v;
      try {
        size_t used = 0;
        v = std::stod(cells[col[k]], &used);
        if (used != cells[col[k]].size()) throw std::invalid_argument("trailing");
      } catch (...) {
        throw Error(path + ":" + std::to_string(lineno) + ": " + names[k] + ": not a number: '" +
                    cells[col[k]] + "'");
      }
      if (!std::isfinite(v) || v < lo || v > hi)
        throw Error(path + ":" + std::to_string(lineno) + ": " + names[k] + ": value " +
                    cells[col[k]] + " outside [" + std::to_string(lo) + ", " + std::to_string(hi) +
                    "]");
      return v;
    };
    SampleRow r;
    // theta is measured from the normal: [0, 180]. phi is periodic: any finite value is a
    // direction (docs/formats.md's angles), so it is accepted as it is.
    const double inf = std::numeric_limits<double>::infinity();
    r.theta_i = get(0, 0, 180);
    r.phi_i = get(1, -inf, inf);
    r.theta_o = get(2, 0, 180);
    r.phi_o = get(3, -inf, inf);
    const double big = 1e30;
    if (t.values == SampleTable::Values::kRGB)
      r.value = {get(4, -big, big), get(5, -big, big), get(6, -big, big)};
    if (t.values == SampleTable::Values::kGrey)
      r.value[0] = r.value[1] = r.value[2] = get(7, -big, big);
    if (t.has_s) r.s = get(8, 0, 1);
    if (t.has_uv) r.u = get(9, -big, big), r.v = get(10, -big, big);
    t.rows.push_back(r);
  }
  if (t.rows.empty()) throw Error(path + ": no data rows");
  return t;
}

void write_table(const std::string& path, const SampleTable& t) {
  std::ostringstream o;
  o.precision(9);
  o << "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg";
  if (t.has_s) o << ",s";
  if (t.has_uv) o << ",u,v";
  o << (t.values == SampleTable::Values::kGrey ? ",y" : ",r,g,b") << "\n";
  for (const auto& r : t.rows) {
    for (double v : r.value)
      if (!std::isfinite(v)) throw Error(path + ": refusing to write a non-finite value");
    o << r.theta_i << "," << r.phi_i << "," << r.theta_o << "," << r.phi_o;
    if (t.has_s) o << "," << r.s;
    if (t.has_uv) o << "," << r.u << "," << r.v;
    if (t.values == SampleTable::Values::kGrey)
      o << "," << r.value[0];
    else
      o << "," << r.value[0] << "," << r.value[1] << "," << r.value[2];
    o << "\n";
  }
  write_text_file(path, o.str());
}

void evaluate_table(const Material& m, SampleTable* t) {
  const Evaluator ev(m);
  const bool local = t->has_uv && m.maps.any();  // the maps at each row's spot
  for (auto& row : t->rows) {
    double f[3];
    const LocalDir L = dir_from_angles(row.theta_i, row.phi_i);
    const LocalDir V = dir_from_angles(row.theta_o, row.phi_o);
    std::optional<Evaluator> here;
    if (local) here.emplace(material_at(m, row.u, row.v));
    const Evaluator& e = here ? *here : ev;
    if (t->has_s)
      e(L, V, f, row.s);
    else
      e(L, V, f);
    for (int c = 0; c < 3; ++c) row.value[c] = f[c];
  }
  t->values = SampleTable::Values::kRGB;
}

TableMisfit table_misfit(const Material& m, const SampleTable& readings) {
  SampleTable model = readings;
  evaluate_table(m, &model);
  return table_misfit(model, readings);
}

TableMisfit table_misfit(const SampleTable& model, const SampleTable& readings) {
  if (model.rows.size() != readings.rows.size())
    throw Error("table_misfit: the model's table has " + std::to_string(model.rows.size()) +
                " rows, the readings " + std::to_string(readings.rows.size()));
  std::map<double, std::pair<double, double>> per;  // theta_o: sum of squares of error, of data
  double e2 = 0, m2 = 0;
  std::vector<double> rel;
  for (size_t i = 0; i < readings.rows.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double d = model.rows[i].value[c] - readings.rows[i].value[c],
                   y = readings.rows[i].value[c];
      e2 += d * d, m2 += y * y;
      auto& p = per[std::round(readings.rows[i].theta_o * 100) / 100];
      p.first += d * d, p.second += y * y;
    }
    const double g = readings.rows[i].value[1];
    if (g > 0) rel.push_back(std::abs(model.rows[i].value[1] / g - 1));
  }
  TableMisfit out;
  out.relative_rms = m2 > 0 ? std::sqrt(e2 / m2) : 0;
  if (!rel.empty()) {
    std::nth_element(rel.begin(), rel.begin() + static_cast<std::ptrdiff_t>(rel.size() / 2),
                     rel.end());
    out.median_relative = rel[rel.size() / 2];
  }
  for (const auto& [theta, p] : per)
    out.relative_rms_by_theta_o.push_back(
        {theta, p.second > 0 ? std::sqrt(p.first / p.second) : 0});
  return out;
}

}  // namespace aniso
