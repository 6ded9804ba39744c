#version 330 core
// Light from an environment (render/bake/environment.h): the prefiltered terms at the fiber T
// (equirectangular over the sphere, z up) and b = <V,T> (the line tables' angle index), summed at
// the angle chi_N of the normal round T.
in vec3 vN; in vec3 vT; in vec3 vP;
uniform sampler3D uEnv[7];
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform float uLevels;
out vec4 frag;
const float PI = 3.14159265358979;
void main() {
  vec3 N = normalize(vN);
  vec3 T = normalize(vT - N * dot(N, vT));
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  vec3 e1 = cross(vec3(0.0, 0.0, 1.0), T);
  if (length(e1) < 1e-6) e1 = cross(vec3(1.0, 0.0, 0.0), T);
  e1 = normalize(e1);
  vec3 e2 = cross(T, e1);
  float c = dot(N, e1), s = dot(N, e2);
  float c2 = c * c - s * s, s2 = 2.0 * c * s;
  float c4 = c2 * c2 - s2 * s2, s4 = 2.0 * c2 * s2;
  float phi = atan(T.y, T.x);
  vec3 st = vec3(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0), acos(clamp(T.z, -1.0, 1.0)) / PI,
                 (acos(clamp(-dot(V, T), -1.0, 1.0)) / PI * (uLevels - 1.0) + 0.5) / uLevels);
  vec3 r = texture(uEnv[0], st).rgb + c * texture(uEnv[1], st).rgb + s * texture(uEnv[2], st).rgb +
           c2 * texture(uEnv[3], st).rgb + s2 * texture(uEnv[4], st).rgb +
           c4 * texture(uEnv[5], st).rgb + s4 * texture(uEnv[6], st).rgb;
  frag = vec4(max(r, vec3(0.0)), 1.0);
}
