#version 330 core
// Light from an environment: render/shaders/aniso_environment.glsl per fragment. A material with
// maps: the environment prefiltered for D alone and for S alone (with a map of n, S at levels of
// n), each at unit k_d or k_s (aniso_environment_parts.glsl), summed with the maps' k_d and k_s at
// the fragment, the fiber turned by its map (render/shaders/maps.glsl). A second fiber reads the
// same tables at T2; the isotropic term comes from its own (environment_isotropic.glsl).
in vec3 vN; in vec3 vT; in vec3 vP; in vec2 vUV;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform int uEnvParts; uniform vec3 uEnvKd; uniform vec3 uEnvKs;
out vec4 frag;
// aniso: aniso_environment.glsl
// aniso: aniso_environment_parts.glsl
// aniso: maps.glsl
// aniso: aniso_environment_isotropic.glsl
// aniso: environment_isotropic.glsl
void main() {
  vec3 N = normalize(vN);
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  vec3 iso = isotropic_environment(N, V);
  if (uEnvParts == 0) {
    vec3 r = anisoEnvironmentRadiance(N, vT, V);
    if (uEnvSecond == 1) r = uEnvW * r + (1.0 - uEnvW) * anisoEnvironmentRadiance(N, vT2, V);
    frag = vec4(r + iso, 1.0);
    return;
  }
  float n = (uMaps & 4) != 0 ? map_at(uNMap, vUV).r : 1.0;  // (one level of n without its map)
  vec3 d, s;
  anisoEnvironmentParts(N, turned_by_map(normalize(vT), N), V, n, d, s);
  if (uEnvSecond == 1) {
    vec3 d2, s2;
    anisoEnvironmentParts(N, normalize(vT2), V, n, d2, s2);
    d = uEnvW * d + (1.0 - uEnvW) * d2;
    s = uEnvW * s + (1.0 - uEnvW) * s2;
  }
  vec3 kd = map_or(1, uKdMap, uEnvKd), ks = map_or(2, uKsMap, uEnvKs);
  frag = vec4(max(kd * d + ks * s, vec3(0.0)) + iso, 1.0);
}
