// Evaluates a Material (plain numbers) for one light: the reflectance per unit irradiance,
// dispatching to the model it names. Used by the simulator, `eval`, `verify` and the bake.
#pragma once
#include <cmath>

#include "core/angles.h"
#include "models/fiber_model.h"
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
  p.psi = deg_to_rad(m.fiber_angle_deg);
  p.isotropic = m.isotropic_active();
  p.n_iso = m.iso_n;
  p.second = m.second_active();
  p.psi2 = deg_to_rad(m.second_angle_deg);
  p.w = m.second_weight;
  return p;
}

// The line part of a fiber material in the fiber's own frame: psi 0, and no second fiber or
// isotropic term (the fiber model has neither), as its baked tables hold it.
inline LineParamsT<double> fiber_frame_params(const Material& m) {
  LineParamsT<double> p = line_params(m);
  p.psi = 0;
  p.second = false;
  p.isotropic = false;
  return p;
}

class Evaluator {
 public:
  explicit Evaluator(const Material& m, FiberAccuracy acc = {})
      : line_(line_params(m)),
        angles_(fiber_angles(line_)),
        fiber_(m.fiber()),
        s_(m.uniform_s()),
        acc_(acc) {}
  // Reflectance for unit irradiance from direction L seen from V (local frame), at a point of
  // topology s (fiber model; ignored by the line model).
  void operator()(const LocalDir& L, const LocalDir& V, double out[3], double s) const {
    if (fiber_)
      fiber_reflectance(line_, s, L, V, acc_, out);
    else
      line_reflectance(line_, angles_, L, V, out);
  }
  // ... with the material's own topology value.
  void operator()(const LocalDir& L, const LocalDir& V, double out[3]) const {
    (*this)(L, V, out, s_);
  }
  bool fiber() const { return fiber_; }

 private:
  LineParamsT<double> line_;
  FiberAngles<double> angles_;  // cos and sin of the fiber angles, once per material
  bool fiber_;
  double s_;
  FiberAccuracy acc_;
};

}  // namespace aniso
