// A texel's sigmas and verdict from J^T J: the 8 x 8 block solve every texel LM step takes, the
// rank test, the diagonal of the inverse. Eigen inside: included by the texel solvers' .cpp files
// and fit/maps/maps.cpp alone.
#pragma once
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "fit/maps/texel_solve.h"

namespace aniso::fitting {

constexpr double kPsiUndeterminedDeg = 10;  // sigma of psi above this: the direction is not known
constexpr double kConditionLimit = 1e-12;   // smallest / largest eigenvalue, column-scaled
constexpr double kTopologyUndetermined = 0.25;  // sigma of s above this: s is not known

// A texel's J^T J (plus a diagonal: the damping, the pull) in the order k_d 3, k_s 3, log n, psi
// has a block structure: channel k's k_d and k_s (rows k and 3 + k) meet no other channel's, only
// the shared log n and psi (rows 6, 7). Solved by eliminating each channel's 2 x 2 block and then
// the shared 2 x 2 (the Schur complement): three 2 x 2 inverses and one more, where a dense 8 x 8
// LDL^T was as long as the texel's float passes. The entries outside the structure are not read.
// False unless every block is positive definite (then so is the matrix); the caller then takes
// Eigen's pivoting LDLT.
struct TexelBlocks {
  double Ai[3][3] = {};    // channel k's block inverse [[a b] [b c]] as {a, b, c}
  double M[3][2][2] = {};  // A_k^-1 B_k: channel k's (k_d, k_s) rows against (log n, psi)
  double Si[3] = {};       // the inverse of the shared block's Schur complement, {a, b, c}

  // {a, b, c}^-1 of a symmetric positive definite 2 x 2; false where it is not one.
  static bool inverse2(double a, double b, double c, double out[3]) {
    const double det = a * c - b * b;
    if (!(a > 0) || !(det > 0) || !std::isfinite(det)) return false;
    const double id = 1 / det;
    out[0] = c * id, out[1] = -b * id, out[2] = a * id;
    return true;
  }
  bool factor(const Mat8& H) {
    double S[3] = {H(6, 6), H(6, 7), H(7, 7)};
    for (int k = 0; k < 3; ++k) {
      if (!inverse2(H(k, k), H(k, 3 + k), H(3 + k, 3 + k), Ai[k])) return false;
      const double* a = Ai[k];
      for (int j = 0; j < 2; ++j) {  // column j of B_k: (H(k, 6 + j), H(3 + k, 6 + j))
        const double b0 = H(k, 6 + j), b1 = H(3 + k, 6 + j);
        M[k][0][j] = a[0] * b0 + a[1] * b1;
        M[k][1][j] = a[1] * b0 + a[2] * b1;
      }
      // S -= B_k^T A_k^-1 B_k = B_k^T M_k
      const double b00 = H(k, 6), b01 = H(k, 7), b10 = H(3 + k, 6), b11 = H(3 + k, 7);
      S[0] -= b00 * M[k][0][0] + b10 * M[k][1][0];
      S[1] -= b00 * M[k][0][1] + b10 * M[k][1][1];
      S[2] -= b01 * M[k][0][1] + b11 * M[k][1][1];
    }
    return inverse2(S[0], S[1], S[2], Si);
  }
  Vec8 solve(const Vec8& b) const {
    double r0 = b(6), r1 = b(7);  // b_s - sum of M_k^T b_k
    for (int k = 0; k < 3; ++k) {
      r0 -= M[k][0][0] * b(k) + M[k][1][0] * b(3 + k);
      r1 -= M[k][0][1] * b(k) + M[k][1][1] * b(3 + k);
    }
    Vec8 x;
    x(6) = Si[0] * r0 + Si[1] * r1;
    x(7) = Si[1] * r0 + Si[2] * r1;
    for (int k = 0; k < 3; ++k) {  // A_k^-1 b_k - M_k x_s
      const double* a = Ai[k];
      x(k) = a[0] * b(k) + a[1] * b(3 + k) - M[k][0][0] * x(6) - M[k][0][1] * x(7);
      x(3 + k) = a[1] * b(k) + a[2] * b(3 + k) - M[k][1][0] * x(6) - M[k][1][1] * x(7);
    }
    return x;
  }
  // The diagonal of H^-1: S^-1 for the shared rows; A_k^-1 + M_k S^-1 M_k^T for channel k's.
  Vec8 inverse_diagonal() const {
    Vec8 d;
    d(6) = Si[0], d(7) = Si[2];
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 2; ++i) {
        const double m0 = M[k][i][0], m1 = M[k][i][1];
        d(i == 0 ? k : 3 + k) =
            Ai[k][2 * i] + m0 * (Si[0] * m0 + Si[1] * m1) + m1 * (Si[1] * m0 + Si[2] * m1);
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

// The sigmas of `info`'s parameters (the diagonal of its inverse times s2) into sigma[0 .. P):
// the rank test on the eigenvalues of the column-scaled matrix first; false where it fails or a
// column is zero (sigma then not written).
template <class M>
bool sigmas_of(const M& info, double s2, double* sigma) {
  using V = Eigen::Matrix<double, M::RowsAtCompileTime, 1>;
  const int P = static_cast<int>(info.rows());
  V scale(P);
  for (int k = 0; k < P; ++k) scale(k) = info(k, k) > 0 ? 1 / std::sqrt(info(k, k)) : 0;
  if (!(scale.minCoeff() > 0)) return false;
  const M scaled = scale.asDiagonal() * info * scale.asDiagonal();
  V var(P);  // the diagonal of scaled^-1, once the rank test has passed
  bool full_rank = false;
  if constexpr (M::RowsAtCompileTime == 8) {
    // The rank test without the eigenvalues where it is clear: the scaled matrix's largest
    // eigenvalue is at most its trace (8), its smallest at least 1 / trace(scaled^-1).
    TexelBlocks f;
    if (f.factor(scaled))
      var = f.inverse_diagonal(), full_rank = 1 / var.sum() > kConditionLimit * 8;
  }
  if (!full_rank) {
    Eigen::SelfAdjointEigenSolver<M> eig(scaled);
    const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
    if (!(lo > kConditionLimit * hi)) return false;
    var = eig.eigenvectors().cwiseAbs2() * eig.eigenvalues().cwiseInverse();
  }
  for (int k = 0; k < P; ++k) sigma[k] = scale(k) * std::sqrt(std::max(var(k), 0.0) * s2);
  return true;
}

// The sigma written for a parameter the data do not move: past any bound's spread (named as not
// known), finite in every file (the maps clamp it to float's largest).
constexpr double kUnmovedSigma = 1e300;
// k_s at or under this in every channel (the start's floor, set_start_kd_ks): the solve found no
// lobe, and n's column is k_s times the lobe's.
constexpr double kNoLobeKs = 1e-4;

// sigmas from J^T J (`info`: fixed 8 x 8, or dynamic) and the residual sum of squares at the
// solution: the rank test on the eigenvalues of the column-scaled matrix, then the diagonal of its
// inverse times s^2. Where the solve found no lobe (k_s at or under kNoLobeKs in every channel),
// `hold` says what is held (NoLobe):
// the line model holds n - its column is k_s times the lobe's, zero at k_s 0 (the LM, on the
// bound) and 1e-4 of the others at the start's floor (Ceres), either way failing the rank test: the
// others' sigmas from the rest of the matrix, n's kUnmovedSigma. (Any other zero column still fails
// it: a lobe at the bounds' corner lit by no pixel is not determined, and is solved again.)
// The fiber model holds k_s too: without a lobe the cost does not depend on n, and its two solvers
// can leave n at opposite bounds with the same sum of squares, where k_s's column is a needle lit
// by a pixel or two or a broad lobe lighting none; holding n alone then decides the rank test
// differently in the two. k_d, psi and s come from the diffuse term alone, the same in both.
// The cases: docs/solver-rules.md "n (and the fiber model's k_s) held without a lobe".
enum class NoLobe { kNone, kHoldN, kHoldLobe };
template <class M>
void texel_sigmas(const M& info, double rss, double values, TexelResult* t,
                  NoLobe hold = NoLobe::kNone) {
  t->rss = rss;
  t->values = values;
  const int P = static_cast<int>(info.rows());
  // The fiber model's lobe is also absent where it lights no pixel (a needle at n 10^4 aimed
  // between them, its k_s anywhere: its column's sum of squares times k_s^2 nothing against rss).
  auto absent = [&](int k) {
    const double ks = t->c.ks[k];
    return ks <= kNoLobeKs ||
           (hold == NoLobe::kHoldLobe && !(ks * ks * info(3 + k, 3 + k) > 1e-12 * rss));
  };
  const bool no_lobe = hold != NoLobe::kNone && absent(0) && absent(1) && absent(2);
  int kept[9], Q = 0;
  for (int k = 0; k < P; ++k) {
    const bool ks = k >= 3 && k < 6;
    const bool held =
        no_lobe && (k == 6 || (ks && (hold == NoLobe::kHoldLobe || !(info(k, k) > 0))));
    if (!held) kept[Q++] = k;
  }
  const double dof = values - Q;
  if (dof < 1) return;
  const double s2 = rss / dof;
  if (Q == P) {
    if (!sigmas_of(info, s2, t->sigma)) return;
  } else {
    Eigen::MatrixXd sub(Q, Q);
    for (int i = 0; i < Q; ++i)
      for (int j = 0; j < Q; ++j) sub(i, j) = info(kept[i], kept[j]);
    double part[9];
    if (!sigmas_of(sub, s2, part)) return;
    for (int k = 0; k < P; ++k) t->sigma[k] = kUnmovedSigma;
    for (int i = 0; i < Q; ++i) t->sigma[kept[i]] = part[i];
  }
  t->determined = rad_to_deg(t->sigma[7]) < kPsiUndeterminedDeg &&
                  (P < 9 || t->sigma[8] < kTopologyUndetermined);
}

}  // namespace aniso::fitting
