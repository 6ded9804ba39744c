#version 330 core
// Isotropic component (Heidrich & Seidel §4): Lambert + Blinn-Phong, one pass per light.
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs; uniform float uN;
out vec4 frag;
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
void main() {
  vec3 L, V, E;
  local_directions(L, V, E);
  vec3 N = normalize(vN);
  float nl = dot(N, L);
  if (nl <= 0.0) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec3 H = normalize(L + V);
  float nh = max(dot(N, H), 0.0);
  frag = vec4(E * (uKd * nl + uKs * (nh > 0.0 ? exp(uN * log(nh)) : 0.0)), 1.0);
}
