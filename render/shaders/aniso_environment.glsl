// aniso: light from an environment for the line-lighting model (render/bake/environment.h): the
// prefiltered terms at the fiber T (equirectangular over the sphere, z up) and b = <V,T> (levels
// at acos(-b) = pi k / (levels - 1)), summed at the angle chi_N of the normal round T, measured
// from e1 = normalize(z x T) (x x T near z) toward e2 = T x e1. `aniso export --env` writes the
// terms (tables/environment_t0..6.ktx2) and this file; `aniso preview --env` draws with it.
uniform sampler3D anisoEnv[7];
uniform float anisoEnvLevels;

// Where the terms are read for (N, T, V) (unit vectors: N the normal, T the fiber, in the
// environment's frame), and the seven terms' weights there.
vec3 anisoEnvironmentCoord(vec3 N, vec3 T, vec3 V, out float w[7]) {
  const float PI = 3.14159265358979;
  T = normalize(T - N * dot(N, T));
  vec3 e1 = cross(vec3(0.0, 0.0, 1.0), T);
  if (length(e1) < 1e-6) e1 = cross(vec3(1.0, 0.0, 0.0), T);
  e1 = normalize(e1);
  vec3 e2 = cross(T, e1);
  float c = dot(N, e1), s = dot(N, e2);
  float c2 = c * c - s * s, s2 = 2.0 * c * s;
  w[0] = 1.0;
  w[1] = c;
  w[2] = s;
  w[3] = c2;
  w[4] = s2;
  w[5] = c2 * c2 - s2 * s2;
  w[6] = 2.0 * c2 * s2;
  float phi = atan(T.y, T.x);
  return vec3(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0), acos(clamp(T.z, -1.0, 1.0)) / PI,
              (acos(clamp(-dot(V, T), -1.0, 1.0)) / PI * (anisoEnvLevels - 1.0) + 0.5) /
                  anisoEnvLevels);
}

// Radiance toward V.
vec3 anisoEnvironmentRadiance(vec3 N, vec3 T, vec3 V) {
  float w[7];
  vec3 st = anisoEnvironmentCoord(N, T, V, w);
  vec3 r = w[0] * texture(anisoEnv[0], st).rgb + w[1] * texture(anisoEnv[1], st).rgb +
           w[2] * texture(anisoEnv[2], st).rgb + w[3] * texture(anisoEnv[3], st).rgb +
           w[4] * texture(anisoEnv[4], st).rgb + w[5] * texture(anisoEnv[5], st).rgb +
           w[6] * texture(anisoEnv[6], st).rgb;
  return max(r, vec3(0.0));
}
