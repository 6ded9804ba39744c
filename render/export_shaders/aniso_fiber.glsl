// aniso: the fiber model (Poulin & Fournier; Hast) from its baked form: the line tables times the
// factor tables G(phi_l, phi_v; s) and F(phi_l, phi_v; s, k) (docs/models.md §5). Include after
// aniso_lookup.glsl and `#define ANISO_NPHI`, `ANISO_NS`, `ANISO_NK` (the export writes them).
//   tables/fiber_G.ktx2: ANISO_NPHI^2 x ANISO_NS layers; tables/fiber_F.ktx2: x ANISO_NS *
//   ANISO_NK layers (layer is * NK + k); R32F; x = phi_l, y = phi_v = atan(<V,B>, <V,N>), texel i
//   at -90 + 180 i / (NPHI - 1) degrees; s at is / (NS - 1); k = kappa / (1 + kappa) at k / (NK - 1).
// s is the topology (0..1) at the fragment; the light's <N,L> is inside G: none is applied here.
uniform sampler2DArray anisoFiberG;
uniform sampler2DArray anisoFiberF;

// Where one light's lookups fall at a fragment: st in the line tables, uv in the factor tables,
// s and k as a lower layer and the next one's weight. False where L or V is below the surface.
struct AnisoFiberLookup {
  vec2 st;
  vec2 uv;
  int is;
  float ws;
  int ik;
  float wk;
};
bool anisoFiberAt(vec3 N, vec3 T, vec3 L, vec3 V, float s, out AnisoFiberLookup f) {
  const float PI = 3.14159265358979;
  T = normalize(T - N * dot(N, T));
  vec3 B = cross(N, T);
  float ln = dot(L, N), vn = dot(V, N);
  if (ln <= 0.0 || vn <= 0.0) return false;
  float a = dot(L, T), b = dot(V, T), lb = dot(L, B), vb = dot(V, B);
  f.st = vec2(anisoCoord(a), anisoCoord(b));
  float sL = length(vec2(lb, ln)), sV = length(vec2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float nphi = float(ANISO_NPHI);
  f.uv = ((vec2(atan(lb, ln), atan(vb, vn)) + 0.5 * PI) / PI * (nphi - 1.0) + 0.5) / nphi;
  float fs = clamp(s, 0.0, 1.0) * float(ANISO_NS - 1);
  f.is = min(int(fs), ANISO_NS - 2);
  f.ws = fs - float(f.is);
  float fk = kk * float(ANISO_NK - 1);
  f.ik = min(int(fk), ANISO_NK - 2);
  f.wk = fk - float(f.ik);
  return true;
}

float anisoFiberGAt(AnisoFiberLookup f) {
  return mix(texture(anisoFiberG, vec3(f.uv, float(f.is))).r,
             texture(anisoFiberG, vec3(f.uv, float(f.is + 1))).r, f.ws);
}

float anisoFiberFAt(AnisoFiberLookup f) {
  float F0 = mix(texture(anisoFiberF, vec3(f.uv, float(f.is * ANISO_NK + f.ik))).r,
                 texture(anisoFiberF, vec3(f.uv, float(f.is * ANISO_NK + f.ik + 1))).r, f.wk);
  float F1 = mix(texture(anisoFiberF, vec3(f.uv, float((f.is + 1) * ANISO_NK + f.ik))).r,
                 texture(anisoFiberF, vec3(f.uv, float((f.is + 1) * ANISO_NK + f.ik + 1))).r, f.wk);
  return mix(F0, F1, f.ws);
}

// Radiance toward V from one light of irradiance E along L; s is the topology (0..1).
vec3 anisoFiberRadiance(vec3 N, vec3 T, vec3 L, vec3 V, float s, vec3 kd, vec3 ks, vec3 E) {
  AnisoFiberLookup f;
  if (!anisoFiberAt(N, T, L, V, s, f)) return vec3(0.0);
  return E * (kd * texture(anisoDiffuse, f.st).r * anisoFiberGAt(f) +
              ks * texture(anisoSpecular, f.st).r * anisoFiberFAt(f));
}
