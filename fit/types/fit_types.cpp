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

}  // namespace aniso
