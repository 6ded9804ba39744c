// aniso: a material with maps (FORMAT.md "Material maps": k_d, k_s, n and the fiber direction
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
