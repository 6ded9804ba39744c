#version 330 core
// Light from an environment: render/shaders/aniso_environment.glsl per fragment. A material with
// maps of k_d, k_s or the fiber direction (one n): the environment prefiltered twice, for D alone
// (anisoEnv) and for S alone (anisoEnvS), each at unit k_d or k_s, summed with the maps' k_d and
// k_s at the fragment, the fiber turned by its map (render/shaders/maps.glsl). A second fiber reads
// the same tables at T2; the isotropic term comes from its own (environment_isotropic.glsl). With a
// map of n, S's terms at uEnvNLevels levels of n (spaced uEnvLogStep in log n from uEnvLogN0) one
// after the other in depth, blended between the two levels either side of the fragment's log n.
in vec3 vN; in vec3 vT; in vec3 vP; in vec2 vUV;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform int uEnvParts; uniform vec3 uEnvKd; uniform vec3 uEnvKs;
uniform int uEnvNLevels; uniform float uEnvLogN0; uniform float uEnvLogStep;
uniform sampler3D anisoEnvS[7];
out vec4 frag;
// aniso: aniso_environment.glsl
// aniso: maps.glsl
// aniso: environment_isotropic.glsl
// S's sum at level k of n (st: the coordinates of one level).
vec3 specular_at(vec3 st, float w[7], float k) {
  st.z = (k + st.z) / float(uEnvNLevels);
  return w[0] * texture(anisoEnvS[0], st).rgb + w[1] * texture(anisoEnvS[1], st).rgb +
         w[2] * texture(anisoEnvS[2], st).rgb + w[3] * texture(anisoEnvS[3], st).rgb +
         w[4] * texture(anisoEnvS[4], st).rgb + w[5] * texture(anisoEnvS[5], st).rgb +
         w[6] * texture(anisoEnvS[6], st).rgb;
}
// D's and S's sums (at unit k_d and k_s) for the fiber T.
void parts_at(vec3 N, vec3 T, vec3 V, out vec3 d, out vec3 s) {
  float w[7];
  vec3 st = anisoEnvironmentCoord(N, T, V, w);
  d = w[0] * texture(anisoEnv[0], st).rgb + w[1] * texture(anisoEnv[1], st).rgb +
      w[2] * texture(anisoEnv[2], st).rgb + w[3] * texture(anisoEnv[3], st).rgb +
      w[4] * texture(anisoEnv[4], st).rgb + w[5] * texture(anisoEnv[5], st).rgb +
      w[6] * texture(anisoEnv[6], st).rgb;
  if (uEnvNLevels < 2) {
    s = specular_at(st, w, 0.0);
    return;
  }
  float n = map_at(uNMap, vUV).r;
  float f = uEnvLogStep > 0.0
                ? clamp((log(max(n, 1e-6)) - uEnvLogN0) / uEnvLogStep, 0.0, float(uEnvNLevels - 1))
                : 0.0;
  float k0 = min(floor(f), float(uEnvNLevels - 2));
  s = mix(specular_at(st, w, k0), specular_at(st, w, k0 + 1.0), f - k0);
}
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
  vec3 d, s;
  parts_at(N, turned_by_map(normalize(vT), N), V, d, s);
  if (uEnvSecond == 1) {
    vec3 d2, s2;
    parts_at(N, normalize(vT2), V, d2, s2);
    d = uEnvW * d + (1.0 - uEnvW) * d2;
    s = uEnvW * s + (1.0 - uEnvW) * s2;
  }
  vec3 kd = map_or(1, uKdMap, uEnvKd), ks = map_or(2, uKsMap, uEnvKs);
  frag = vec4(max(kd * d + ks * s, vec3(0.0)) + iso, 1.0);
}
