// aniso: the fiber model (Poulin & Fournier; Hast) from its baked form: the line tables times the
// factor tables G(phi_l, phi_v; s) and F(phi_l, phi_v; s, k) (MODELS.md §5). Include after
// aniso_lookup.glsl and `#define ANISO_NPHI`, `ANISO_NS`, `ANISO_NK` (the export writes them).
//   tables/fiber_G.ktx2: ANISO_NPHI^2 x ANISO_NS layers; tables/fiber_F.ktx2: x ANISO_NS *
//   ANISO_NK layers (layer is * NK + k); R32F; x = phi_l, y = phi_v = atan(<V,B>, <V,N>), texel i
//   at -90 + 180 i / (NPHI - 1) degrees; s at is / (NS - 1); k = kappa / (1 + kappa) at k / (NK - 1).
// s is the topology (0..1) at the fragment; the light's <N,L> is inside G: none is applied here.
uniform sampler2DArray anisoFiberG;
uniform sampler2DArray anisoFiberF;

vec3 anisoFiberRadiance(vec3 N, vec3 T, vec3 L, vec3 V, float s, vec3 kd, vec3 ks, vec3 E) {
  const float PI = 3.14159265358979;
  T = normalize(T - N * dot(N, T));
  vec3 B = cross(N, T);
  float ln = dot(L, N), vn = dot(V, N);
  if (ln <= 0.0 || vn <= 0.0) return vec3(0.0);
  float a = dot(L, T), b = dot(V, T), lb = dot(L, B), vb = dot(V, B);
  vec2 st = vec2(anisoCoord(a), anisoCoord(b));
  float Dl = texture(anisoDiffuse, st).r;
  float Sl = texture(anisoSpecular, st).r;
  float sL = length(vec2(lb, ln)), sV = length(vec2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float nphi = float(ANISO_NPHI);
  vec2 uv = ((vec2(atan(lb, ln), atan(vb, vn)) + 0.5 * PI) / PI * (nphi - 1.0) + 0.5) / nphi;
  float fs = clamp(s, 0.0, 1.0) * float(ANISO_NS - 1);
  int is = min(int(fs), ANISO_NS - 2);
  float ws = fs - float(is);
  float fk = kk * float(ANISO_NK - 1);
  int ik = min(int(fk), ANISO_NK - 2);
  float wk = fk - float(ik);
  float G = mix(texture(anisoFiberG, vec3(uv, float(is))).r,
                texture(anisoFiberG, vec3(uv, float(is + 1))).r, ws);
  float F0 = mix(texture(anisoFiberF, vec3(uv, float(is * ANISO_NK + ik))).r,
                 texture(anisoFiberF, vec3(uv, float(is * ANISO_NK + ik + 1))).r, wk);
  float F1 = mix(texture(anisoFiberF, vec3(uv, float((is + 1) * ANISO_NK + ik))).r,
                 texture(anisoFiberF, vec3(uv, float((is + 1) * ANISO_NK + ik + 1))).r, wk);
  return E * (kd * Dl * G + ks * Sl * mix(F0, F1, ws));
}
