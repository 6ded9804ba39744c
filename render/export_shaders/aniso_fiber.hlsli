// aniso: the fiber model (Poulin & Fournier; Hast) from its baked form: the line tables times the
// factor tables G(phi_l, phi_v; s) and F(phi_l, phi_v; s, k) (MODELS.md §5). Include after
// aniso_lookup.hlsli and ANISO_NPHI, ANISO_NS, ANISO_NK defined (the export writes them).
// Layout as in aniso_fiber.glsl; Texture2DArray slices are whole layers (no filtering across).
Texture2DArray<float> anisoFiberG : register(t2);
Texture2DArray<float> anisoFiberF : register(t3);

float3 anisoFiberRadiance(float3 N, float3 T, float3 L, float3 V, float s, float3 kd, float3 ks,
                          float3 E) {
  const float PI = 3.14159265358979;
  T = normalize(T - N * dot(N, T));
  float3 B = cross(N, T);
  float ln = dot(L, N), vn = dot(V, N);
  if (ln <= 0.0 || vn <= 0.0) return float3(0.0, 0.0, 0.0);
  float a = dot(L, T), b = dot(V, T), lb = dot(L, B), vb = dot(V, B);
  float2 st = float2(anisoCoord(a), anisoCoord(b));
  float Dl = anisoDiffuse.Sample(anisoLinearClamp, st);
  float Sl = anisoSpecular.Sample(anisoLinearClamp, st);
  float sL = length(float2(lb, ln)), sV = length(float2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float nphi = float(ANISO_NPHI);
  float2 uv = ((float2(atan2(lb, ln), atan2(vb, vn)) + 0.5 * PI) / PI * (nphi - 1.0) + 0.5) / nphi;
  float fs = clamp(s, 0.0, 1.0) * float(ANISO_NS - 1);
  int is = min(int(fs), ANISO_NS - 2);
  float ws = fs - float(is);
  float fk = kk * float(ANISO_NK - 1);
  int ik = min(int(fk), ANISO_NK - 2);
  float wk = fk - float(ik);
  float G = lerp(anisoFiberG.Sample(anisoLinearClamp, float3(uv, is)),
                 anisoFiberG.Sample(anisoLinearClamp, float3(uv, is + 1)), ws);
  float F0 = lerp(anisoFiberF.Sample(anisoLinearClamp, float3(uv, is * ANISO_NK + ik)),
                  anisoFiberF.Sample(anisoLinearClamp, float3(uv, is * ANISO_NK + ik + 1)), wk);
  float F1 = lerp(anisoFiberF.Sample(anisoLinearClamp, float3(uv, (is + 1) * ANISO_NK + ik)),
                  anisoFiberF.Sample(anisoLinearClamp, float3(uv, (is + 1) * ANISO_NK + ik + 1)),
                  wk);
  return E * (kd * Dl * G + ks * Sl * lerp(F0, F1, ws));
}
