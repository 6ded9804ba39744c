#version 330 core
// The anisotropic pass: the paper's texture matrix applied to (T, 1), two lookups (D, S) so the
// colours stay uniforms, and Banks' self-shadowing <N,L>^+ per fragment.
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform mat4 uTexMat;
uniform sampler2D uD;
uniform sampler2D uS;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs;
uniform float uWeight; uniform int uUseT2;
uniform int uAngleIndex; uniform float uTexels;
out vec4 frag;
const float PI = 3.14159265358979;
void main() {
  vec3 N = normalize(vN);
  vec3 T = uUseT2 == 1 ? vT2 : vT;
  T = normalize(T - N * dot(N, T));
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uAngleIndex == 1)  // s = (a + 1) / 2 -> texel centre of acos(-a) (render/bake.h)
    st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  float D = texture(uD, st).r;
  float S = texture(uS, st).r;
  frag = vec4(uE * uWeight * (uKd * D + uKs * S) * max(dot(N, uL), 0.0), 1.0);
}
