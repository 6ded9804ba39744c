#version 330 core
layout(location = 0) in vec3 aP;
layout(location = 1) in vec3 aN;
layout(location = 2) in vec3 aT;
layout(location = 3) in vec3 aT2;
layout(location = 4) in vec2 aUV;
layout(location = 5) in float aSmath;
uniform mat4 uViewProj;
out vec3 vN; out vec3 vT; out vec3 vT2; out vec2 vUV; out float vSmath; out vec3 vP;
invariant gl_Position;
void main() {
  vN = aN; vT = aT; vT2 = aT2; vUV = aUV; vSmath = aSmath; vP = aP;
  gl_Position = uViewProj * vec4(aP, 1.0);
}
