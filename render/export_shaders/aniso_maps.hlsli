// aniso: a material with maps (FORMAT.md "Material maps") from the exported tables and maps, as
// shaders/aniso_maps.glsl (read it for the files and their layout). Include after
// aniso_lookup.hlsli; the export defines ANISO_KD_MAP, ANISO_KS_MAP, ANISO_FIBER_MAP and
// ANISO_N_MAP (with ANISO_STACK_LEVELS, ANISO_LOG_N0, ANISO_LOG_STEP) for the maps the material
// has. The maps' sampler (s1) is linear, no mipmaps, addressed as export.json's maps.wrap says.
#ifdef ANISO_KD_MAP
Texture2D<float4> anisoKdMap : register(t4);
#endif
#ifdef ANISO_KS_MAP
Texture2D<float4> anisoKsMap : register(t5);
#endif
#ifdef ANISO_FIBER_MAP
Texture2D<float4> anisoFiberMap : register(t6);
#endif
#ifdef ANISO_N_MAP
Texture2D<float> anisoNMap : register(t7);
Texture2DArray<float> anisoSpecularStack : register(t8);
#endif
SamplerState anisoMapSampler : register(s1);

// The material at texture coordinates uv: each value the material has a map of is replaced by
// the map's (kd, ks, T; n, returned 0 without a map of n), the others left as passed.
float anisoMapsAt(float2 uv, float3 N, inout float3 T, inout float3 kd, inout float3 ks) {
#ifdef ANISO_KD_MAP
  kd = anisoKdMap.Sample(anisoMapSampler, uv).rgb;
#endif
#ifdef ANISO_KS_MAP
  ks = anisoKsMap.Sample(anisoMapSampler, uv).rgb;
#endif
#ifdef ANISO_FIBER_MAP
  float2 c = anisoFiberMap.Sample(anisoMapSampler, uv).rg;
  float psi = dot(c, c) > 0.0 ? 0.5 * atan2(c.y, c.x) : 0.0;
  T = normalize(T - N * dot(N, T));
  T = cos(psi) * T + sin(psi) * cross(N, T);
#endif
#ifdef ANISO_N_MAP
  return anisoNMap.Sample(anisoMapSampler, uv);
#else
  return 0.0;
#endif
}

// S at table coordinates st for the exponent n: the stack with a map of n, else the one table.
float anisoSpecularAt(float2 st, float n) {
#ifdef ANISO_N_MAP
  float f = clamp((log(max(n, 1e-6)) - ANISO_LOG_N0) / ANISO_LOG_STEP, 0.0,
                  float(ANISO_STACK_LEVELS - 1));
  float k0 = min(floor(f), float(ANISO_STACK_LEVELS - 2));
  float s0 = anisoSpecularStack.Sample(anisoLinearClamp, float3(st, k0));
  float s1 = anisoSpecularStack.Sample(anisoLinearClamp, float3(st, k0 + 1.0));
  return s0 + (f - k0) * (s1 - s0);
#else
  return anisoSpecular.Sample(anisoLinearClamp, st);
#endif
}

// Radiance toward V from one light of irradiance E along L at texture coordinates uv; kd and ks
// are the material's values where it has no map of them.
float3 anisoRadianceMapped(float3 N, float3 T, float2 uv, float3 L, float3 V, float3 kd,
                           float3 ks, float3 E) {
  float n = anisoMapsAt(uv, N, T, kd, ks);
  T = normalize(T - N * dot(N, T));
  float2 st = float2(anisoCoord(dot(L, T)), anisoCoord(dot(V, T)));
  float D = anisoDiffuse.Sample(anisoLinearClamp, st);
  return E * (kd * D + ks * anisoSpecularAt(st, n)) * max(dot(N, L), 0.0);
}
