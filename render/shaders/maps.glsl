// The material maps of the preview's passes (docs/formats.md "Material maps"), spliced by
// render/preview.cpp into aniso.frag and fiber.frag where they say "// aniso: maps.glsl" (after
// their `in vec2 vUV`). Bits of uMaps: 1 k_d, 2 k_s, 4 n (the line pass), 8 the fiber direction,
// 16 the topology map's amplitude (the fiber pass). Read texel by texel and filtered here in
// float as the CPU does (core/texture.h: bilinear, texel centres at (i + 1/2) / W, clamped or
// repeated), so the reference sees the same values. With a map of n, S comes from the stack of
// specular tables (render/bake.h: SpecularStack): the two levels either side of the fragment's
// log n, blended by its exact weight.
uniform int uMaps; uniform int uRepeat;
uniform sampler2D uKdMap; uniform sampler2D uKsMap; uniform sampler2D uNMap; uniform sampler2D uFiberMap;
uniform sampler2D uAmpMap;
uniform sampler2DArray uSStack; uniform int uLevels; uniform float uLogN0; uniform float uLogStep;
ivec2 wrap_texel(ivec2 i, ivec2 n) {
  return uRepeat == 1 ? ivec2(mod(vec2(i), vec2(n))) : clamp(i, ivec2(0), n - 1);
}
vec4 map_at(sampler2D m, vec2 uv) {
  ivec2 n = textureSize(m, 0);
  vec2 x = uv * vec2(n) - 0.5, f = floor(x), t = x - f;
  ivec2 a = wrap_texel(ivec2(f), n), b = wrap_texel(ivec2(f) + 1, n);
  return (1.0 - t.x) * (1.0 - t.y) * texelFetch(m, a, 0) + t.x * (1.0 - t.y) * texelFetch(m, ivec2(b.x, a.y), 0) +
         (1.0 - t.x) * t.y * texelFetch(m, ivec2(a.x, b.y), 0) + t.x * t.y * texelFetch(m, b, 0);
}
// The map of `bit` at the fragment, or `scalar` where the material has none.
vec3 map_or(int bit, sampler2D m, vec3 scalar) {
  return (uMaps & bit) != 0 ? map_at(m, vUV).rgb : scalar;
}
float stack_at(vec2 st, float n) {
  float f = uLogStep > 0.0 ? clamp((log(n) - uLogN0) / uLogStep, 0.0, float(uLevels - 1)) : 0.0;
  float k0 = min(floor(f), float(uLevels - 2));
  float s0 = texture(uSStack, vec3(st, k0)).r, s1 = texture(uSStack, vec3(st, k0 + 1.0)).r;
  return s0 + (f - k0) * (s1 - s0);
}
// With a map of the fiber direction the vertex tangent is the reference tangent U: T turned by the
// map's psi about N (W = N x U, as the CPU's frame).
vec3 turned_by_map(vec3 T, vec3 N) {
  if ((uMaps & 8) == 0) return T;
  vec2 c = map_at(uFiberMap, vUV).rg;
  float psi = dot(c, c) > 0.0 ? 0.5 * atan(c.y, c.x) : 0.0;
  return cos(psi) * T + sin(psi) * cross(N, T);
}
