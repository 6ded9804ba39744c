#version 330 core
// Light from an environment: render/shaders/aniso_environment.glsl per fragment. A material with
// maps of k_d, k_s or the fiber direction (one n): the environment prefiltered twice, for D alone
// (anisoEnv) and for S alone (anisoEnvS), each at unit k_d or k_s, summed with the maps' k_d and
// k_s at the fragment, the fiber turned by its map (render/shaders/maps.glsl).
in vec3 vN; in vec3 vT; in vec3 vP; in vec2 vUV;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform int uEnvParts; uniform vec3 uEnvKd; uniform vec3 uEnvKs;
uniform sampler3D anisoEnvS[7];
out vec4 frag;
// aniso: aniso_environment.glsl
// aniso: maps.glsl
void main() {
  vec3 N = normalize(vN);
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  if (uEnvParts == 0) {
    frag = vec4(anisoEnvironmentRadiance(N, vT, V), 1.0);
    return;
  }
  vec3 T = turned_by_map(normalize(vT), N);
  float w[7];
  vec3 st = anisoEnvironmentCoord(N, T, V, w);
  vec3 d = w[0] * texture(anisoEnv[0], st).rgb + w[1] * texture(anisoEnv[1], st).rgb +
           w[2] * texture(anisoEnv[2], st).rgb + w[3] * texture(anisoEnv[3], st).rgb +
           w[4] * texture(anisoEnv[4], st).rgb + w[5] * texture(anisoEnv[5], st).rgb +
           w[6] * texture(anisoEnv[6], st).rgb;
  vec3 s = w[0] * texture(anisoEnvS[0], st).rgb + w[1] * texture(anisoEnvS[1], st).rgb +
           w[2] * texture(anisoEnvS[2], st).rgb + w[3] * texture(anisoEnvS[3], st).rgb +
           w[4] * texture(anisoEnvS[4], st).rgb + w[5] * texture(anisoEnvS[5], st).rgb +
           w[6] * texture(anisoEnvS[6], st).rgb;
  vec3 kd = map_or(1, uKdMap, uEnvKd), ks = map_or(2, uKsMap, uEnvKs);
  frag = vec4(max(kd * d + ks * s, vec3(0.0)), 1.0);
}
