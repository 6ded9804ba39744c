#include "fit/types/fit_types.h"

namespace aniso {

const char* fit_model_name(FitModel m) {
  switch (m) {
    case FitModel::kLine:
      return "line";
    case FitModel::kFiber:
      return "fiber";
    case FitModel::kAuto:
      break;
  }
  return "auto";
}

const char* fit_loss_name(FitLoss l) {
  switch (l) {
    case FitLoss::kHuber:
      return "huber";
    case FitLoss::kCauchy:
      return "cauchy";
    case FitLoss::kNone:
      break;
  }
  return "none";
}

const char* psi_symmetry_name(PsiSymmetry p) {
  switch (p) {
    case PsiSymmetry::kAlways:
      return "always";
    case PsiSymmetry::kNever:
      return "never";
    case PsiSymmetry::kAuto:
      break;
  }
  return "auto";
}

namespace {
constexpr std::pair<WarningAbout, const char*> kWarningAbout[] = {
    {WarningAbout::kOther, "other"},
    {WarningAbout::kGlobalMisfit, "global_misfit"},
    {WarningAbout::kMaps, "maps"},
    {WarningAbout::kTile, "tile"},
    {WarningAbout::kFiberAngle, "fiber_angle"},
    {WarningAbout::kSolverStopped, "solver_stopped"},
};
}  // namespace

const char* warning_about_name(WarningAbout about) {
  for (const auto& [a, name] : kWarningAbout)
    if (a == about) return name;
  return "other";
}

WarningAbout warning_about_named(const std::string& name) {
  for (const auto& [a, n] : kWarningAbout)
    if (name == n) return a;
  return WarningAbout::kOther;
}

WarningAbout warning_about_from_words(const std::string& text) {
  const auto starts = [&](const char* w) { return text.rfind(w, 0) == 0; };
  if (starts("--maps: ")) return WarningAbout::kMaps;
  if (starts("tile ")) return WarningAbout::kTile;
  if (starts("fiber_angle_deg: ")) return WarningAbout::kFiberAngle;
  if (starts("the solver stopped")) return WarningAbout::kSolverStopped;
  if (starts("the model does not describe the data") ||
      starts("one parameter set for the whole sample"))
    return WarningAbout::kGlobalMisfit;
  return WarningAbout::kOther;
}

}  // namespace aniso
