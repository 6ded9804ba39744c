#version 330 core
// A plain textured-and-lit pass (ordinary uv texture times Lambert), for timing comparisons.
in vec3 vN; in vec3 vT; in vec3 vT2;
uniform sampler2D uD;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd;
out vec4 frag;
void main() {
  vec3 N = normalize(vN);
  float tex = texture(uD, vT.xy * 0.5 + 0.5).r;
  frag = vec4(uE * uKd * tex * max(dot(N, uL), 0.0), 1.0);
}
