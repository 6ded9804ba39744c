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
in vec2 vUV;
// aniso: maps.glsl
void main() {
  vec3 L, V, E;
  local_directions(L, V, E);
  vec3 N = normalize(vN);
  vec3 T = uUseT2 == 1 ? vT2 : vT;
  T = normalize(T - N * dot(N, T));
  if (uUseT2 == 0) T = turned_by_map(T, N);
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uPointLight == 1 || uPerspective == 1) {  // the texture matrix's job, per fragment
    st = 0.5 + 0.5 * vec2(dot(L, T), dot(V, T));
    if (uAngleIndex == 0) st = st * (uTexels - 1.0) / uTexels + 0.5 / uTexels;
  }
  if (uAngleIndex == 1)  // s = (a + 1) / 2 -> texel centre of acos(-a) (render/bake.h)
    st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  float D = texture(uD, st).r;
  float S = (uMaps & 4) != 0 ? stack_at(st, max(map_at(uNMap, vUV).r, 1e-30)) : texture(uS, st).r;
  vec3 kd = map_or(1, uKdMap, uKd), ks = map_or(2, uKsMap, uKs);
  frag = vec4(E * uWeight * (kd * D + ks * S) * max(dot(N, L), 0.0), 1.0);
}
