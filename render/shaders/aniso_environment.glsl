// aniso: light from an environment for the line-lighting model (render/bake/environment.h): the
// prefiltered terms at the fiber T (equirectangular over the sphere, z up) and b = <V,T> (levels
// at acos(-b) = pi k / (levels - 1)), summed at the angle chi_N of the normal round T, measured
// from e1 = normalize(z x T) (x x T near z) toward e2 = T x e1. `aniso export --env` writes the
// terms (tables/environment_t0..6.ktx2) and this file; `aniso preview --env` draws with it.
uniform sampler3D anisoEnv[7];
uniform float anisoEnvLevels;

// Radiance toward V (unit vectors: N the normal, T the fiber, in the environment's frame).
vec3 anisoEnvironmentRadiance(vec3 N, vec3 T, vec3 V) {
  const float PI = 3.14159265358979;
  T = normalize(T - N * dot(N, T));
  vec3 e1 = cross(vec3(0.0, 0.0, 1.0), T);
  if (length(e1) < 1e-6) e1 = cross(vec3(1.0, 0.0, 0.0), T);
  e1 = normalize(e1);
  vec3 e2 = cross(T, e1);
  float c = dot(N, e1), s = dot(N, e2);
  float c2 = c * c - s * s, s2 = 2.0 * c * s;
  float c4 = c2 * c2 - s2 * s2, s4 = 2.0 * c2 * s2;
  float phi = atan(T.y, T.x);
  vec3 st = vec3(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0), acos(clamp(T.z, -1.0, 1.0)) / PI,
                 (acos(clamp(-dot(V, T), -1.0, 1.0)) / PI * (anisoEnvLevels - 1.0) + 0.5) /
                     anisoEnvLevels);
  vec3 r = texture(anisoEnv[0], st).rgb + c * texture(anisoEnv[1], st).rgb +
           s * texture(anisoEnv[2], st).rgb + c2 * texture(anisoEnv[3], st).rgb +
           s2 * texture(anisoEnv[4], st).rgb + c4 * texture(anisoEnv[5], st).rgb +
           s4 * texture(anisoEnv[6], st).rgb;
  return max(r, vec3(0.0));
}
