// aniso: a material with maps (docs/formats.md "Material maps": k_d, k_s, n and the fiber direction
// over the sample's texture coordinates) from the exported tables and maps. Include after
// aniso_lookup.glsl; the export defines which maps the material has: ANISO_KD_MAP, ANISO_KS_MAP,
// ANISO_FIBER_MAP and ANISO_N_MAP (with ANISO_STACK_LEVELS, ANISO_LOG_N0, ANISO_LOG_STEP).
//   tables/maps/kd.ktx2, ks.ktx2 (RGBA32F, RGB used), n.ktx2 (R32F), fiber.ktx2 (RGBA32F, RG =
//   cos 2psi, sin 2psi): t = v, the first stored row at v = 0 (glTF's texture coordinates); sample
//   with GL_LINEAR, no mipmaps, wrap as export.json's maps.wrap says (clamp or repeat).
//   tables/specular_stack.ktx2 (with a map of n): S(a, b; n) at ANISO_STACK_LEVELS values of n,
//   layer k at log n = ANISO_LOG_N0 + k ANISO_LOG_STEP, indexed as the line tables; a fragment's
//   S blends the two layers either side of its log n.
// Without a map of the fiber direction T is the fiber direction as in anisoRadiance; with one, T
// is the reference tangent U (the mesh tangent, not turned) and the map turns it by psi about N.
// The fiber model (after aniso_fiber.glsl): anisoFiberRadianceMapped, with a map of n F from
// tables/fiber_F_stack.ktx2, and the topology over uv (ANISO_S_MAP, ANISO_TOPOLOGY_MAP,
// ANISO_AMPLITUDE_MAP or ANISO_TOPOLOGY_AMPLITUDE) by anisoTopologyAt; see the end of this file.
#ifdef ANISO_KD_MAP
uniform sampler2D anisoKdMap;
#endif
#ifdef ANISO_KS_MAP
uniform sampler2D anisoKsMap;
#endif
#ifdef ANISO_FIBER_MAP
uniform sampler2D anisoFiberMap;
#endif
#ifdef ANISO_N_MAP
uniform sampler2D anisoNMap;
uniform sampler2DArray anisoSpecularStack;
#endif

// The material at texture coordinates uv: each value the material has a map of is replaced by
// the map's (kd, ks, T; n, returned 0 without a map of n), the others left as passed.
float anisoMapsAt(vec2 uv, vec3 N, inout vec3 T, inout vec3 kd, inout vec3 ks) {
#ifdef ANISO_KD_MAP
  kd = texture(anisoKdMap, uv).rgb;
#endif
#ifdef ANISO_KS_MAP
  ks = texture(anisoKsMap, uv).rgb;
#endif
#ifdef ANISO_FIBER_MAP
  vec2 c = texture(anisoFiberMap, uv).rg;
  float psi = dot(c, c) > 0.0 ? 0.5 * atan(c.y, c.x) : 0.0;
  T = normalize(T - N * dot(N, T));
  T = cos(psi) * T + sin(psi) * cross(N, T);
#endif
#ifdef ANISO_N_MAP
  return texture(anisoNMap, uv).r;
#else
  return 0.0;
#endif
}

// S at table coordinates st for the exponent n: the stack with a map of n, else the one table.
float anisoSpecularAt(vec2 st, float n) {
#ifdef ANISO_N_MAP
  float f = clamp((log(max(n, 1e-6)) - ANISO_LOG_N0) / ANISO_LOG_STEP, 0.0,
                  float(ANISO_STACK_LEVELS - 1));
  float k0 = min(floor(f), float(ANISO_STACK_LEVELS - 2));
  float s0 = texture(anisoSpecularStack, vec3(st, k0)).r;
  float s1 = texture(anisoSpecularStack, vec3(st, k0 + 1.0)).r;
  return s0 + (f - k0) * (s1 - s0);
#else
  return texture(anisoSpecular, st).r;
#endif
}

// Radiance toward V from one light of irradiance E along L at texture coordinates uv; kd and ks
// are the material's values where it has no map of them.
vec3 anisoRadianceMapped(vec3 N, vec3 T, vec2 uv, vec3 L, vec3 V, vec3 kd, vec3 ks, vec3 E) {
  float n = anisoMapsAt(uv, N, T, kd, ks);
  T = normalize(T - N * dot(N, T));
  vec2 st = vec2(anisoCoord(dot(L, T)), anisoCoord(dot(V, T)));
  float D = texture(anisoDiffuse, st).r;
  return E * (kd * D + ks * anisoSpecularAt(st, n)) * max(dot(N, L), 0.0);
}

#ifdef ANISO_NPHI
// The fiber model's topology over uv (docs/models.md §4), repeated as in docs/formats.md (sample with
// GL_REPEAT, GL_LINEAR): with ANISO_S_MAP a map of s itself (R32F); with ANISO_TOPOLOGY_MAP the
// topology map h in [0, 1] (R32F, m = 2h - 1) and its amplitude, ANISO_TOPOLOGY_AMPLITUDE or, with
// ANISO_AMPLITUDE_MAP, a map of it (R32F, wrap as maps.wrap).
#ifdef ANISO_S_MAP
uniform sampler2D anisoSMap;
#endif
#ifdef ANISO_TOPOLOGY_MAP
uniform sampler2D anisoTopologyMap;
#endif
#ifdef ANISO_AMPLITUDE_MAP
uniform sampler2D anisoAmplitudeMap;
#endif

// The topology at uv: s as passed without a topology map; a map of s's value; with a topology map
// the climb of height H = clamp(2 sin(60 deg s) + A m, 0, sqrt 3), s passed as the shape's
// mathematical topology s_math (0 for a flat sample).
float anisoTopologyAt(vec2 uv, float s) {
#if defined(ANISO_S_MAP)
  return clamp(texture(anisoSMap, uv).r, 0.0, 1.0);
#elif defined(ANISO_TOPOLOGY_MAP)
  const float PI = 3.14159265358979;
  float m = 2.0 * texture(anisoTopologyMap, uv).r - 1.0;
#ifdef ANISO_AMPLITUDE_MAP
  float A = texture(anisoAmplitudeMap, uv).r;
#else
  float A = ANISO_TOPOLOGY_AMPLITUDE;
#endif
  float H = clamp(2.0 * sin(PI / 3.0 * s) + A * m, 0.0, sqrt(3.0));
  return asin(0.5 * H) / (PI / 3.0);
#else
  return s;
#endif
}

// The fiber model with maps: include after aniso_fiber.glsl. With a map of n, S_line comes from the
// specular stack and F from tables/fiber_F_stack.ktx2: F's tables at ANISO_FIBER_F_LEVELS values
// of n, layer level * ANISO_NS + is, its ANISO_NK tables of phi side by side (tile k: x = (k + u)
// / ANISO_NK, so that filtering stays inside the tile), level at log n = ANISO_FIBER_LOG_N0 +
// level ANISO_FIBER_LOG_STEP; a fragment's F blends the two levels either side of its log n.
#ifdef ANISO_N_MAP
uniform sampler2DArray anisoFiberFStack;

float anisoFiberFStackAt(AnisoFiberLookup f, float n) {
  float x = clamp((log(max(n, 1e-6)) - ANISO_FIBER_LOG_N0) / ANISO_FIBER_LOG_STEP, 0.0,
                  float(ANISO_FIBER_F_LEVELS - 1));
  float k0 = min(floor(x), float(ANISO_FIBER_F_LEVELS - 2));
  vec2 a = vec2((float(f.ik) + f.uv.x) / float(ANISO_NK), f.uv.y);
  vec2 b = a + vec2(1.0 / float(ANISO_NK), 0.0);
  float Fl[2];
  for (int l = 0; l < 2; ++l) {
    float layer = (k0 + float(l)) * float(ANISO_NS) + float(f.is);
    float f0 = mix(texture(anisoFiberFStack, vec3(a, layer)).r,
                   texture(anisoFiberFStack, vec3(b, layer)).r, f.wk);
    float f1 = mix(texture(anisoFiberFStack, vec3(a, layer + 1.0)).r,
                   texture(anisoFiberFStack, vec3(b, layer + 1.0)).r, f.wk);
    Fl[l] = mix(f0, f1, f.ws);
  }
  return Fl[0] + (x - k0) * (Fl[1] - Fl[0]);
}
#endif

// Radiance toward V from one light of irradiance E along L at texture coordinates uv, topology s
// (anisoTopologyAt: with a topology map s is s_math); kd and ks are the material's values where it
// has no map of them.
vec3 anisoFiberRadianceMapped(vec3 N, vec3 T, vec2 uv, vec3 L, vec3 V, float s, vec3 kd, vec3 ks,
                              vec3 E) {
  float n = anisoMapsAt(uv, N, T, kd, ks);
  AnisoFiberLookup f;
  if (!anisoFiberAt(N, T, L, V, anisoTopologyAt(uv, s), f)) return vec3(0.0);
#ifdef ANISO_N_MAP
  float F = anisoFiberFStackAt(f, n);
#else
  float F = anisoFiberFAt(f);
#endif
  return E * (kd * texture(anisoDiffuse, f.st).r * anisoFiberGAt(f) +
              ks * anisoSpecularAt(f.st, n) * F);
}
#endif
