#version 330 core
// Light from an environment: render/shaders/aniso_environment.glsl per fragment.
in vec3 vN; in vec3 vT; in vec3 vP;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
out vec4 frag;
// aniso: aniso_environment.glsl
void main() {
  vec3 N = normalize(vN);
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  frag = vec4(anisoEnvironmentRadiance(N, vT, V), 1.0);
}
