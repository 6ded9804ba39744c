// A texel's sigmas and verdict from J^T J: the 8 x 8 LDL^T every texel LM step solves with, the
// rank test, the diagonal of the inverse. Eigen inside: included by fit/texel_solve.cpp alone.
#pragma once
#include <Eigen/Dense>
#include <cmath>

#include "core/angles.h"
#include "fit/texel_solve.h"

namespace aniso::fitting {

constexpr double kPsiUndeterminedDeg = 10;  // sigma of psi above this: the direction is not known
constexpr double kConditionLimit = 1e-12;   // smallest / largest eigenvalue, column-scaled
constexpr double kTopologyUndetermined = 0.25;  // sigma of s above this: s is not known

// A = L D L^T of a symmetric 8 x 8 matrix (unit lower L, no pivoting): what every LM step of a
// texel solves with, written out because Eigen's dynamic kernels behind a fixed 8 x 8 solve cost
// more than the texel's float passes. False unless every pivot is positive and finite (the
// caller then takes Eigen's pivoting LDLT).
struct Ldl8 {
  double L[8][8] = {}, D[8] = {}, Dinv[8] = {};  // Dinv: 1 / D (one division per pivot)
  bool factor(const Mat8& A) {
    for (int j = 0; j < 8; ++j) {
      double LD[8];  // L[j][k] D[k]
      double d = A(j, j);
      for (int k = 0; k < j; ++k) LD[k] = L[j][k] * D[k], d -= L[j][k] * LD[k];
      if (!(d > 0) || !std::isfinite(d)) return false;
      D[j] = d, Dinv[j] = 1 / d, L[j][j] = 1;
      for (int i = j + 1; i < 8; ++i) {
        double v = A(i, j);
        for (int k = 0; k < j; ++k) v -= L[i][k] * LD[k];
        L[i][j] = v * Dinv[j];
      }
    }
    return true;
  }
  Vec8 solve(const Vec8& b) const {
    double y[8];
    for (int i = 0; i < 8; ++i) {
      y[i] = b(i);
      for (int k = 0; k < i; ++k) y[i] -= L[i][k] * y[k];
    }
    Vec8 x;
    for (int i = 7; i >= 0; --i) {
      double v = y[i] * Dinv[i];
      for (int k = i + 1; k < 8; ++k) v -= L[k][i] * x(k);
      x(i) = v;
    }
    return x;
  }
  // The diagonal of A^-1 = L^-T D^-1 L^-1: sum over j of (L^-1)_jk^2 / D_j.
  Vec8 inverse_diagonal() const {
    double M[8][8] = {};  // L^-1, unit lower
    for (int k = 0; k < 8; ++k) {
      M[k][k] = 1;
      for (int i = k + 1; i < 8; ++i) {
        double v = 0;
        for (int m = k; m < i; ++m) v -= L[i][m] * M[m][k];
        M[i][k] = v;
      }
    }
    Vec8 d;
    for (int k = 0; k < 8; ++k) {
      double s = 0;
      for (int j = k; j < 8; ++j) s += M[j][k] * M[j][k] * Dinv[j];
      d(k) = s;
    }
    return d;
  }
};

// A texel whose solver stopped at its iteration limit is marked, and not determined: its numbers
// are not a minimum's (the global values are kept for it, as for any undetermined texel).
inline void mark_converged(bool converged, TexelResult* t) {
  t->converged = converged;
  if (!converged) t->determined = false;
}

// sigmas from J^T J (`info`: fixed 8 x 8, or dynamic) and the residual sum of squares at the
// solution: the rank test on the eigenvalues of the column-scaled matrix, then the diagonal of its
// inverse times s^2.
template <class M>
void texel_sigmas(const M& info, double rss, double values, TexelResult* t) {
  using V = Eigen::Matrix<double, M::RowsAtCompileTime, 1>;
  t->rss = rss;
  t->values = values;
  const int P = static_cast<int>(info.rows());
  const double dof = values - P;
  if (dof < 1) return;
  const double s2 = rss / dof;
  V scale(P);
  for (int k = 0; k < P; ++k) scale(k) = info(k, k) > 0 ? 1 / std::sqrt(info(k, k)) : 0;
  if (!(scale.minCoeff() > 0)) return;
  const M scaled = scale.asDiagonal() * info * scale.asDiagonal();
  V var(P);  // the diagonal of scaled^-1, once the rank test has passed
  bool full_rank = false;
  if constexpr (M::RowsAtCompileTime == 8) {
    // The rank test without the eigenvalues where it is clear: the scaled matrix's largest
    // eigenvalue is at most its trace (8), its smallest at least 1 / trace(scaled^-1).
    Ldl8 f;
    if (f.factor(scaled))
      var = f.inverse_diagonal(), full_rank = 1 / var.sum() > kConditionLimit * 8;
  }
  if (!full_rank) {
    Eigen::SelfAdjointEigenSolver<M> eig(scaled);
    const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
    if (!(lo > kConditionLimit * hi)) return;
    var = eig.eigenvectors().cwiseAbs2() * eig.eigenvalues().cwiseInverse();
  }
  for (int k = 0; k < P; ++k) t->sigma[k] = scale(k) * std::sqrt(std::max(var(k), 0.0) * s2);
  t->determined = rad_to_deg(t->sigma[7]) < kPsiUndeterminedDeg &&
                  (P < 9 || t->sigma[8] < kTopologyUndetermined);
}

}  // namespace aniso::fitting
