#version 330 core
// The anisotropic pass: the paper's texture matrix applied to (T, 1), two lookups (D, S) so the
// colours stay uniforms, and Banks' self-shadowing <N,L>^+ per fragment.
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform mat4 uTexMat;
uniform sampler2D uD;
uniform sampler2D uS;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs;
uniform float uWeight; uniform int uUseT2;
uniform int uAngleIndex; uniform float uTexels;
out vec4 frag;
const float PI = 3.14159265358979;
// A point light (uPointLight: at uLightPos, irradiance uE at distance uLightD0, falling off as
// 1/d^2) and a perspective viewer (uPerspective: at uEye) make L and V vary per fragment.
in vec3 vP;
uniform int uPointLight; uniform vec3 uLightPos; uniform float uLightD0;
uniform int uPerspective; uniform vec3 uEye;
void local_directions(out vec3 L, out vec3 V, out vec3 E) {
  L = uL; V = uV; E = uE;
  if (uPointLight == 1) {
    vec3 d = uLightPos - vP;
    float r = length(d);
    L = d / r;
    E = uE * (uLightD0 * uLightD0) / (r * r);
  }
  if (uPerspective == 1) V = normalize(uEye - vP);
}
// Material maps (FORMAT.md "Material maps"; bits of uMaps: 1 k_d, 2 k_s, 4 n, 8 the fiber
// direction), read texel by texel and filtered here in float as the CPU does (core/texture.h:
// bilinear, texel centres at (i + 1/2) / W, clamped or repeated), so the reference sees the same
// values. With a map of n, S comes from the stack of specular tables (render/bake.h: SpecularStack): the
// two levels either side of the fragment's log n, blended by its exact weight.
in vec2 vUV;
uniform int uMaps; uniform int uRepeat;
uniform sampler2D uKdMap; uniform sampler2D uKsMap; uniform sampler2D uNMap; uniform sampler2D uFiberMap;
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
float stack_at(vec2 st, float n) {
  float f = uLogStep > 0.0 ? clamp((log(n) - uLogN0) / uLogStep, 0.0, float(uLevels - 1)) : 0.0;
  float k0 = min(floor(f), float(uLevels - 2));
  float s0 = texture(uSStack, vec3(st, k0)).r, s1 = texture(uSStack, vec3(st, k0 + 1.0)).r;
  return s0 + (f - k0) * (s1 - s0);
}
void main() {
  vec3 L, V, E;
  local_directions(L, V, E);
  vec3 N = normalize(vN);
  vec3 T = uUseT2 == 1 ? vT2 : vT;
  T = normalize(T - N * dot(N, T));
  if (uUseT2 == 0 && (uMaps & 8) != 0) {  // vT is the reference tangent U here: turn it by psi
    vec2 c = map_at(uFiberMap, vUV).rg;
    float psi = dot(c, c) > 0.0 ? 0.5 * atan(c.y, c.x) : 0.0;
    T = cos(psi) * T + sin(psi) * cross(N, T);
  }
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uPointLight == 1 || uPerspective == 1) {  // the texture matrix's job, per fragment
    st = 0.5 + 0.5 * vec2(dot(L, T), dot(V, T));
    if (uAngleIndex == 0) st = st * (uTexels - 1.0) / uTexels + 0.5 / uTexels;
  }
  if (uAngleIndex == 1)  // s = (a + 1) / 2 -> texel centre of acos(-a) (render/bake.h)
    st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  float D = texture(uD, st).r;
  float S = (uMaps & 4) != 0 ? stack_at(st, max(map_at(uNMap, vUV).r, 1e-30)) : texture(uS, st).r;
  vec3 kd = (uMaps & 1) != 0 ? map_at(uKdMap, vUV).rgb : uKd;
  vec3 ks = (uMaps & 2) != 0 ? map_at(uKsMap, vUV).rgb : uKs;
  frag = vec4(E * uWeight * (kd * D + ks * S) * max(dot(N, L), 0.0), 1.0);
}
