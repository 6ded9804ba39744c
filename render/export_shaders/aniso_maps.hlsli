// aniso: a material with maps (docs/formats.md "Material maps") from the exported tables and maps, as
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

#ifdef ANISO_NPHI
// The fiber model's topology over uv, as in aniso_maps.glsl; its maps' sampler (s2) is linear, no
// mipmaps, addressed wrap (repeat), but the map of the amplitude's, which is the maps' (s1).
#ifdef ANISO_S_MAP
Texture2D<float> anisoSMap : register(t10);
#endif
#ifdef ANISO_TOPOLOGY_MAP
Texture2D<float> anisoTopologyMap : register(t11);
#endif
#ifdef ANISO_AMPLITUDE_MAP
Texture2D<float> anisoAmplitudeMap : register(t12);
#endif
#if defined(ANISO_S_MAP) || defined(ANISO_TOPOLOGY_MAP)
SamplerState anisoTopologySampler : register(s2);
#endif

// The topology at uv: s as passed without a topology map; a map of s's value; with a topology map
// the climb of height H = clamp(2 sin(60 deg s) + A m, 0, sqrt 3), s passed as the shape's
// mathematical topology s_math (0 for a flat sample).
float anisoTopologyAt(float2 uv, float s) {
#if defined(ANISO_S_MAP)
  return saturate(anisoSMap.Sample(anisoTopologySampler, uv));
#elif defined(ANISO_TOPOLOGY_MAP)
  const float PI = 3.14159265358979;
  float m = 2.0 * anisoTopologyMap.Sample(anisoTopologySampler, uv) - 1.0;
#ifdef ANISO_AMPLITUDE_MAP
  float A = anisoAmplitudeMap.Sample(anisoMapSampler, uv);
#else
  float A = ANISO_TOPOLOGY_AMPLITUDE;
#endif
  float H = clamp(2.0 * sin(PI / 3.0 * s) + A * m, 0.0, sqrt(3.0));
  return asin(0.5 * H) / (PI / 3.0);
#else
  return s;
#endif
}

// The fiber model with maps: include after aniso_fiber.hlsli; layout as in aniso_maps.glsl.
#ifdef ANISO_N_MAP
Texture2DArray<float> anisoFiberFStack : register(t9);

float anisoFiberFStackAt(AnisoFiberLookup f, float n) {
  float x = clamp((log(max(n, 1e-6)) - ANISO_FIBER_LOG_N0) / ANISO_FIBER_LOG_STEP, 0.0,
                  float(ANISO_FIBER_F_LEVELS - 1));
  float k0 = min(floor(x), float(ANISO_FIBER_F_LEVELS - 2));
  float2 a = float2((float(f.ik) + f.uv.x) / float(ANISO_NK), f.uv.y);
  float2 b = a + float2(1.0 / float(ANISO_NK), 0.0);
  float Fl[2];
  for (int l = 0; l < 2; ++l) {
    float layer = (k0 + float(l)) * float(ANISO_NS) + float(f.is);
    float f0 = lerp(anisoFiberFStack.Sample(anisoLinearClamp, float3(a, layer)),
                    anisoFiberFStack.Sample(anisoLinearClamp, float3(b, layer)), f.wk);
    float f1 = lerp(anisoFiberFStack.Sample(anisoLinearClamp, float3(a, layer + 1.0)),
                    anisoFiberFStack.Sample(anisoLinearClamp, float3(b, layer + 1.0)), f.wk);
    Fl[l] = lerp(f0, f1, f.ws);
  }
  return Fl[0] + (x - k0) * (Fl[1] - Fl[0]);
}
#endif

// Radiance toward V from one light of irradiance E along L at texture coordinates uv, topology s
// (anisoTopologyAt: with a topology map s is s_math); kd and ks are the material's values where it
// has no map of them.
float3 anisoFiberRadianceMapped(float3 N, float3 T, float2 uv, float3 L, float3 V, float s,
                                float3 kd, float3 ks, float3 E) {
  float n = anisoMapsAt(uv, N, T, kd, ks);
  AnisoFiberLookup f;
  if (!anisoFiberAt(N, T, L, V, anisoTopologyAt(uv, s), f)) return float3(0.0, 0.0, 0.0);
#ifdef ANISO_N_MAP
  float F = anisoFiberFStackAt(f, n);
#else
  float F = anisoFiberFAt(f);
#endif
  return E * (kd * anisoDiffuse.Sample(anisoLinearClamp, f.st) * anisoFiberGAt(f) +
              ks * anisoSpecularAt(f.st, n) * F);
}
#endif
