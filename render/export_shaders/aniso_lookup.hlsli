// aniso: the line-lighting model (Banks 1994; Heidrich & Seidel 1998) from the exported tables.
// Define ANISO_TEXELS (the table size N) before including (the export's aniso_ps.hlsl does).
//   tables/diffuse.ktx2, tables/specular.ktx2: N x N, R32_FLOAT, linear values, no sRGB;
//   u = <L,T>, v = <V,T>, texel i at the angle acos(-c) = pi i / (N - 1); v = 0 is the first
//   row; sample linear, clamp, no mipmaps.
Texture2D<float> anisoDiffuse : register(t0);
Texture2D<float> anisoSpecular : register(t1);
SamplerState anisoLinearClamp : register(s0);

float anisoCoord(float c) {
  const float PI = 3.14159265358979;
  return (acos(clamp(-c, -1.0, 1.0)) / PI * (ANISO_TEXELS - 1.0) + 0.5) / ANISO_TEXELS;
}

// Radiance toward V from one light of irradiance E along L (all unit vectors, one space).
float3 anisoRadiance(float3 N, float3 T, float3 L, float3 V, float3 kd, float3 ks, float3 E) {
  T = normalize(T - N * dot(N, T));
  float2 uv = float2(anisoCoord(dot(L, T)), anisoCoord(dot(V, T)));
  float D = anisoDiffuse.Sample(anisoLinearClamp, uv);
  float S = anisoSpecular.Sample(anisoLinearClamp, uv);
  return E * (kd * D + ks * S) * max(dot(N, L), 0.0);
}
