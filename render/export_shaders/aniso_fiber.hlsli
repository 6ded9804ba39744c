// aniso: the fiber model (Poulin & Fournier; Hast) from its baked form: the line tables times the
// factor tables G(phi_l, phi_v; s) and F(phi_l, phi_v; s, k) (docs/models.md §5). Include after
// aniso_lookup.hlsli and ANISO_NPHI, ANISO_NS, ANISO_NK defined (the export writes them).
// Layout as in aniso_fiber.glsl; Texture2DArray slices are whole layers (no filtering across).
Texture2DArray<float> anisoFiberG : register(t2);
Texture2DArray<float> anisoFiberF : register(t3);

// Where one light's lookups fall at a fragment (as aniso_fiber.glsl): false where L or V is below
// the surface.
struct AnisoFiberLookup {
  float2 st;
  float2 uv;
  int is;
  float ws;
  int ik;
  float wk;
};
bool anisoFiberAt(float3 N, float3 T, float3 L, float3 V, float s, out AnisoFiberLookup f) {
  const float PI = 3.14159265358979;
  f = (AnisoFiberLookup)0;
  T = normalize(T - N * dot(N, T));
  float3 B = cross(N, T);
  float ln = dot(L, N), vn = dot(V, N);
  if (ln <= 0.0 || vn <= 0.0) return false;
  float a = dot(L, T), b = dot(V, T), lb = dot(L, B), vb = dot(V, B);
  f.st = float2(anisoCoord(a), anisoCoord(b));
  float sL = length(float2(lb, ln)), sV = length(float2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float nphi = float(ANISO_NPHI);
  f.uv = ((float2(atan2(lb, ln), atan2(vb, vn)) + 0.5 * PI) / PI * (nphi - 1.0) + 0.5) / nphi;
  float fs = clamp(s, 0.0, 1.0) * float(ANISO_NS - 1);
  f.is = min(int(fs), ANISO_NS - 2);
  f.ws = fs - float(f.is);
  float fk = kk * float(ANISO_NK - 1);
  f.ik = min(int(fk), ANISO_NK - 2);
  f.wk = fk - float(f.ik);
  return true;
}

float anisoFiberGAt(AnisoFiberLookup f) {
  return lerp(anisoFiberG.Sample(anisoLinearClamp, float3(f.uv, f.is)),
              anisoFiberG.Sample(anisoLinearClamp, float3(f.uv, f.is + 1)), f.ws);
}

float anisoFiberFAt(AnisoFiberLookup f) {
  float F0 = lerp(anisoFiberF.Sample(anisoLinearClamp, float3(f.uv, f.is * ANISO_NK + f.ik)),
                  anisoFiberF.Sample(anisoLinearClamp, float3(f.uv, f.is * ANISO_NK + f.ik + 1)),
                  f.wk);
  float F1 =
      lerp(anisoFiberF.Sample(anisoLinearClamp, float3(f.uv, (f.is + 1) * ANISO_NK + f.ik)),
           anisoFiberF.Sample(anisoLinearClamp, float3(f.uv, (f.is + 1) * ANISO_NK + f.ik + 1)),
           f.wk);
  return lerp(F0, F1, f.ws);
}

// Radiance toward V from one light of irradiance E along L; s is the topology (0..1).
float3 anisoFiberRadiance(float3 N, float3 T, float3 L, float3 V, float s, float3 kd, float3 ks,
                          float3 E) {
  AnisoFiberLookup f;
  if (!anisoFiberAt(N, T, L, V, s, f)) return float3(0.0, 0.0, 0.0);
  return E * (kd * anisoDiffuse.Sample(anisoLinearClamp, f.st) * anisoFiberGAt(f) +
              ks * anisoSpecular.Sample(anisoLinearClamp, f.st) * anisoFiberFAt(f));
}
