// aniso: light from an environment for the fiber model (render/bake/environment_fiber.h): per term
// of the Fourier series in chi, the environment's integral at the fiber T (and level of b = <V,T>
// for S) times the coefficient of G or F at phi_v (V's angle from N toward B in the cross-section)
// and the topology s, turned by the normal's angle chi_N round T. anisoFibEnvD holds D's terms as
// layers; anisoFibEnvS S's terms with their levels of b side by side in depth (term t's level i at
// layer t * levels + i), the levels of n one above the other (anisoFibEnvRows rows each: the rows
// of level kn from kn * rows); anisoFibEnvCoef the coefficients over
// (phi_v, b), three to a layer (F's then G's), the layers of each level of s after those of the
// one before and each level of n's after the one before. Levels of s and of n are blended between
// the two either side of the fragment's. `aniso export --env` writes the tables
// (tables/fiber_environment_*.ktx2) and this file; `aniso preview --env` draws with it.
uniform sampler3D anisoFibEnvD;
uniform sampler3D anisoFibEnvS;
uniform sampler3D anisoFibEnvCoef;
uniform int anisoFibEnvOrder; uniform float anisoFibEnvLevels; uniform float anisoFibEnvPhis;
uniform int anisoFibEnvSLevels;
uniform int anisoFibEnvNLevels; uniform float anisoFibEnvLogN0; uniform float anisoFibEnvLogStep;
uniform float anisoFibEnvRows;
const int kAnisoFibEnvMaxTerms = 17;  // order 8

// The coefficients at level kn of n (F's then G's) at the table coordinates cst, blended between
// the two levels of s either side of topo.
void anisoFibEnvCoefficients(vec2 cst, float topo, int kn, out float cf[2 * kAnisoFibEnvMaxTerms + 2]) {
  int nt = 2 * anisoFibEnvOrder + 1;
  int layers = (2 * nt + 2) / 3;
  float fs = anisoFibEnvSLevels > 1 ? clamp(topo, 0.0, 1.0) * float(anisoFibEnvSLevels - 1) : 0.0;
  int s0 = min(int(fs), max(anisoFibEnvSLevels - 2, 0));
  float ws = fs - float(s0);
  float all_layers = float(layers * anisoFibEnvSLevels * anisoFibEnvNLevels);
  for (int l = 0; l < layers; ++l) {
    float z0 = (float((kn * anisoFibEnvSLevels + s0) * layers + l) + 0.5) / all_layers;
    vec3 v = texture(anisoFibEnvCoef, vec3(cst, z0)).rgb;
    if (ws > 0.0) v = mix(v, texture(anisoFibEnvCoef, vec3(cst, z0 + float(layers) / all_layers)).rgb, ws);
    cf[3 * l] = v.r;
    cf[3 * l + 1] = v.g;
    cf[3 * l + 2] = v.b;
  }
}

// D's and S's sums at unit k_d and k_s for N, the fiber T (unit, perpendicular to N) and V (unit,
// <N,V> > 0), at topology s and exponent n (which matters only where the tables hold levels of n).
void anisoFiberEnvironmentParts(vec3 N, vec3 T, vec3 V, float topo, float n, out vec3 d,
                                out vec3 s) {
  const float PI = 3.14159265358979;
  vec3 B = cross(N, T);
  vec3 e1 = cross(vec3(0.0, 0.0, 1.0), T);
  if (length(e1) < 1e-6) e1 = cross(vec3(1.0, 0.0, 0.0), T);
  e1 = normalize(e1);
  vec3 e2 = cross(T, e1);
  float c1 = dot(N, e1), s1 = dot(N, e2);
  float phi = atan(T.y, T.x);
  vec2 st = vec2(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0), acos(clamp(T.z, -1.0, 1.0)) / PI);
  float levels = anisoFibEnvLevels;
  float level = acos(clamp(-dot(V, T), -1.0, 1.0)) / PI * (levels - 1.0);
  float phi_v = atan(dot(V, B), dot(V, N));
  vec2 cst = vec2(((phi_v + 0.5 * PI) / PI * (anisoFibEnvPhis - 1.0) + 0.5) / anisoFibEnvPhis,
                  (level + 0.5) / levels);
  int nt = 2 * anisoFibEnvOrder + 1;
  int nl = anisoFibEnvNLevels;
  float fn = nl > 1 && anisoFibEnvLogStep > 0.0
                 ? clamp((log(max(n, 1e-6)) - anisoFibEnvLogN0) / anisoFibEnvLogStep, 0.0,
                         float(nl - 1))
                 : 0.0;
  int n0 = min(int(fn), max(nl - 2, 0));
  float wn = fn - float(n0);
  float depth = float(nt) * levels;
  // T's row within a level of n, held off the level's edges (as clamping to the edge would).
  float row = clamp(st.y * anisoFibEnvRows, 0.5, anisoFibEnvRows - 0.5);
  d = vec3(0.0);
  s = vec3(0.0);
  for (int r = 0; r < 2; ++r) {
    float wr = r == 0 ? 1.0 - wn : wn;
    if (wr <= 0.0) continue;
    int kn = n0 + r;
    float cf[2 * kAnisoFibEnvMaxTerms + 2];
    anisoFibEnvCoefficients(cst, topo, kn, cf);
    float base = level + 0.5;
    vec2 sn = vec2(st.x, (float(kn) * anisoFibEnvRows + row) / (anisoFibEnvRows * float(nl)));
    vec3 dr = cf[nt] * texture(anisoFibEnvD, vec3(st, 0.5 / float(nt))).rgb;
    vec3 sr = cf[0] * texture(anisoFibEnvS, vec3(sn, base / depth)).rgb;
    float ck = 1.0, sk = 0.0;
    for (int k = 1; k <= anisoFibEnvOrder; ++k) {
      float c2 = ck * c1 - sk * s1;
      sk = sk * c1 + ck * s1;
      ck = c2;
      int tc = 2 * k - 1, ts = 2 * k;
      // A coefficient pair (c on cos(k phi_l), s on sin(k phi_l)) turned onto the integrals with
      // cos(k chi) and sin(k chi): phi_l = chi_N - chi.
      float fc = cf[tc] * ck + cf[ts] * sk, fsn = cf[tc] * sk - cf[ts] * ck;
      float gc = cf[nt + tc] * ck + cf[nt + ts] * sk, gs = cf[nt + tc] * sk - cf[nt + ts] * ck;
      dr += gc * texture(anisoFibEnvD, vec3(st, (float(tc) + 0.5) / float(nt))).rgb +
            gs * texture(anisoFibEnvD, vec3(st, (float(ts) + 0.5) / float(nt))).rgb;
      sr += fc * texture(anisoFibEnvS, vec3(sn, (float(tc) * levels + base) / depth)).rgb +
            fsn * texture(anisoFibEnvS, vec3(sn, (float(ts) * levels + base) / depth)).rgb;
    }
    d += wr * dr;
    s += wr * sr;
  }
}

// Radiance toward V: k_d D + k_s S (0 where V is below the surface).
vec3 anisoFiberEnvironmentRadiance(vec3 N, vec3 T, vec3 V, float topo, float n, vec3 kd, vec3 ks) {
  if (dot(N, V) <= 0.0) return vec3(0.0);
  vec3 d, s;
  anisoFiberEnvironmentParts(N, normalize(T - N * dot(N, T)), V, topo, n, d, s);
  return max(kd * d + ks * s, vec3(0.0));
}
