#version 330 core
// Geometry pass for the reference: N, T, T2 (orthonormalised like the shading pass); for the
// fiber model the third target holds (u, v, s_math) instead of T2; the fourth the position, the fifth (u, v).
in vec3 vN; in vec3 vT; in vec3 vT2; in vec2 vUV; in float vSmath; in vec3 vP;
uniform int uFiber;
layout(location = 0) out vec4 oN;
layout(location = 1) out vec4 oT;
layout(location = 2) out vec4 oT2;
layout(location = 3) out vec4 oP;  // position (point lights, perspective)
layout(location = 4) out vec4 oUV;  // texture coordinates (material maps)
void main() {
  vec3 N = normalize(vN);
  oN = vec4(N, 1.0);
  oT = vec4(normalize(vT - N * dot(N, vT)), 1.0);
  oP = vec4(vP, 1.0);
  oUV = vec4(vUV, 0.0, 1.0);
  oT2 = uFiber == 1 ? vec4(vUV, vSmath, 1.0) : vec4(normalize(vT2 - N * dot(N, vT2)), 1.0);
}
