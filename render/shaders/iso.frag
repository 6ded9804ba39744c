#version 330 core
// Isotropic component (seed 000 §4): Lambert + Blinn-Phong, one pass per light.
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs; uniform float uN;
out vec4 frag;
void main() {
  vec3 N = normalize(vN);
  float nl = dot(N, uL);
  if (nl <= 0.0) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec3 H = normalize(uL + uV);
  float nh = max(dot(N, H), 0.0);
  frag = vec4(uE * (uKd * nl + uKs * (nh > 0.0 ? exp(uN * log(nh)) : 0.0)), 1.0);
}
