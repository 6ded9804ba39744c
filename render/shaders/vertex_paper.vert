#version 330 core
// The paper's construction to the letter: the texture matrix applied per vertex to (T, 1), the
// coordinates interpolated, one lookup per table, <N,L>^+ per fragment.
layout(location = 0) in vec3 aP;
layout(location = 1) in vec3 aN;
layout(location = 2) in vec3 aT;
uniform mat4 uViewProj;
uniform mat4 uTexMat;
out vec3 vN; out vec2 vST;
invariant gl_Position;
void main() { vN = aN; vST = (uTexMat * vec4(aT, 1.0)).xy; gl_Position = uViewProj * vec4(aP, 1.0); }
