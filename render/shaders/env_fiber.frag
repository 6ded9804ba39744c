#version 330 core
// The fiber model under an environment (render/bake/environment_fiber.h): per term of the Fourier
// series in chi, the environment's integral at the fiber T (and level of b = <V,T> for S) times
// the coefficient of G or F at phi_v (V's angle from N toward B in the cross-section), turned by
// the normal's angle chi_N round T. uFibEnvD holds D's terms as layers, uFibEnvS S's terms with
// their levels of b side by side in depth (term t's level i at layer t * levels + i), uFibEnvCoef
// the coefficients over (phi_v, b), three to a layer (F's then G's), the layers of each level of
// the topology s after those of the one before (blended between the two levels either side of the
// fragment's s). Maps of k_d, k_s and the fiber direction apply per fragment (maps.glsl), the
// topology s as the fiber pass takes it (topology.glsl); a second fiber reads the same tables at
// T2, the isotropic term its own (environment_isotropic.glsl).
in vec3 vN; in vec3 vT; in vec3 vP; in vec2 vUV;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform vec3 uEnvKd; uniform vec3 uEnvKs;
uniform sampler3D uFibEnvD;
uniform sampler3D uFibEnvS;
uniform sampler3D uFibEnvCoef;
uniform int uFibEnvOrder; uniform float uFibEnvLevels; uniform float uFibEnvPhis;
uniform int uFibEnvSLevels;
out vec4 frag;
// aniso: maps.glsl
// aniso: topology.glsl
// aniso: environment_isotropic.glsl
const int kMaxTerms = 17;  // order 8
// D's and S's sums (at unit k_d and k_s) for the fiber T at topology s.
void parts_at(vec3 N, vec3 T, vec3 V, float topo, out vec3 d, out vec3 s) {
  const float PI = 3.14159265358979;
  vec3 B = cross(N, T);
  vec3 e1 = cross(vec3(0.0, 0.0, 1.0), T);
  if (length(e1) < 1e-6) e1 = cross(vec3(1.0, 0.0, 0.0), T);
  e1 = normalize(e1);
  vec3 e2 = cross(T, e1);
  float c1 = dot(N, e1), s1 = dot(N, e2);
  float phi = atan(T.y, T.x);
  vec2 st = vec2(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0), acos(clamp(T.z, -1.0, 1.0)) / PI);
  float levels = uFibEnvLevels;
  float level = acos(clamp(-dot(V, T), -1.0, 1.0)) / PI * (levels - 1.0);
  float phi_v = atan(dot(V, B), dot(V, N));
  vec2 cst = vec2(((phi_v + 0.5 * PI) / PI * (uFibEnvPhis - 1.0) + 0.5) / uFibEnvPhis,
                  (level + 0.5) / levels);
  int nt = 2 * uFibEnvOrder + 1;
  int layers = (2 * nt + 2) / 3;
  float fs = uFibEnvSLevels > 1 ? clamp(topo, 0.0, 1.0) * float(uFibEnvSLevels - 1) : 0.0;
  int s0 = min(int(fs), max(uFibEnvSLevels - 2, 0));
  float ws = fs - float(s0);
  float all_layers = float(layers * uFibEnvSLevels);
  float cf[2 * kMaxTerms + 2];
  for (int l = 0; l < layers; ++l) {
    float z0 = (float(s0 * layers + l) + 0.5) / all_layers;
    vec3 v = texture(uFibEnvCoef, vec3(cst, z0)).rgb;
    if (ws > 0.0) v = mix(v, texture(uFibEnvCoef, vec3(cst, z0 + float(layers) / all_layers)).rgb, ws);
    cf[3 * l] = v.r;
    cf[3 * l + 1] = v.g;
    cf[3 * l + 2] = v.b;
  }
  float depth = float(nt) * levels;
  d = cf[nt] * texture(uFibEnvD, vec3(st, 0.5 / float(nt))).rgb;
  s = cf[0] * texture(uFibEnvS, vec3(st, (level + 0.5) / depth)).rgb;
  float ck = 1.0, sk = 0.0;
  for (int k = 1; k <= uFibEnvOrder; ++k) {
    float c2 = ck * c1 - sk * s1;
    sk = sk * c1 + ck * s1;
    ck = c2;
    int tc = 2 * k - 1, ts = 2 * k;
    // A coefficient pair (c on cos(k phi_l), s on sin(k phi_l)) turned onto the integrals with
    // cos(k chi) and sin(k chi): phi_l = chi_N - chi.
    float fc = cf[tc] * ck + cf[ts] * sk, fsn = cf[tc] * sk - cf[ts] * ck;
    float gc = cf[nt + tc] * ck + cf[nt + ts] * sk, gs = cf[nt + tc] * sk - cf[nt + ts] * ck;
    d += gc * texture(uFibEnvD, vec3(st, (float(tc) + 0.5) / float(nt))).rgb +
         gs * texture(uFibEnvD, vec3(st, (float(ts) + 0.5) / float(nt))).rgb;
    s += fc * texture(uFibEnvS, vec3(st, (float(tc) * levels + level + 0.5) / depth)).rgb +
         fsn * texture(uFibEnvS, vec3(st, (float(ts) * levels + level + 0.5) / depth)).rgb;
  }
}
void main() {
  vec3 N = normalize(vN);
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  vec3 iso = isotropic_environment(N, V);
  if (dot(N, V) <= 0.0) {
    frag = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  float topo = topology_at();
  vec3 d, s;
  parts_at(N, turned_by_map(normalize(vT - N * dot(N, vT)), N), V, topo, d, s);
  if (uEnvSecond == 1) {
    vec3 d2, s2;
    parts_at(N, normalize(vT2 - N * dot(N, vT2)), V, topo, d2, s2);
    d = uEnvW * d + (1.0 - uEnvW) * d2;
    s = uEnvW * s + (1.0 - uEnvW) * s2;
  }
  vec3 kd = map_or(1, uKdMap, uEnvKd), ks = map_or(2, uKsMap, uEnvKs);
  frag = vec4(max(kd * d + ks * s, vec3(0.0)) + iso, 1.0);
}
