#version 330 core
in vec3 vN; in vec2 vST;
uniform sampler2D uD; uniform sampler2D uS;
uniform vec3 uL; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs; uniform float uWeight;
out vec4 frag;
void main() {
  frag = vec4(uE * uWeight * (uKd * texture(uD, vST).r + uKs * texture(uS, vST).r) * max(dot(normalize(vN), uL), 0.0), 1.0);
}
