// Evaluates a Material (plain numbers) for one light: the reflectance per unit irradiance,
// dispatching to the model it names. Used by the simulator, `eval`, `verify` and the bake.
#pragma once
#include <cmath>

#include "models/line_model.h"
#include "models/material.h"

namespace aniso {

inline LineParamsT<double> line_params(const Material& m) {
  LineParamsT<double> p;
  for (int k = 0; k < 3; ++k) {
    p.kd[k] = m.kd[k];
    p.ks[k] = m.ks[k];
    p.kd_iso[k] = m.iso_kd[k];
    p.ks_iso[k] = m.iso_ks[k];
  }
  p.n = m.n;
  p.psi = m.fiber_angle_deg * M_PI / 180.0;
  p.isotropic = m.isotropic_active();
  p.n_iso = m.iso_n;
  p.second = m.second_active();
  p.psi2 = m.second_angle_deg * M_PI / 180.0;
  p.w = m.second_weight;
  return p;
}

class Evaluator {
 public:
  explicit Evaluator(const Material& m) : line_(line_params(m)) {}
  // Reflectance for unit irradiance from direction L seen from V (local frame).
  void operator()(const LocalDir& L, const LocalDir& V, double out[3]) const {
    line_reflectance(line_, L, V, out);
  }

 private:
  LineParamsT<double> line_;
};

}  // namespace aniso
