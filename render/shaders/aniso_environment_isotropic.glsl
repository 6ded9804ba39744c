// aniso: the isotropic term k_d,iso <N,L>^+ + k_s,iso (<N,H>^+)^n_iso under an environment
// (render/bake/environment.h IsotropicEnvironment): the irradiance over N and the Phong lobe over
// V's mirror direction R, equirectangular tables (z up), the lobe times its factor over <N,V>
// (anisoEnvIsoScale[i] at <N,V> = i / 32). `aniso export --env` writes the tables
// (tables/environment_isotropic_irradiance.ktx2, _glossy.ktx2, the factor in export.json) and this
// file; `aniso preview --env` draws with it.
uniform sampler3D anisoEnvIrr; uniform sampler3D anisoEnvGloss;
uniform float anisoEnvIsoScale[33];
vec3 anisoEnvDirectionAt(sampler3D table, vec3 D) {
  const float PI = 3.14159265358979;
  float phi = atan(D.y, D.x);
  return texture(table, vec3(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0),
                             acos(clamp(D.z, -1.0, 1.0)) / PI, 0.5)).rgb;
}
vec3 anisoIsotropicEnvironment(vec3 N, vec3 V, vec3 kd_iso, vec3 ks_iso) {
  float nv = clamp(dot(N, V), 0.0, 1.0) * 32.0;
  int i = min(int(nv), 31);
  float scale = mix(anisoEnvIsoScale[i], anisoEnvIsoScale[i + 1], nv - float(i));
  vec3 R = 2.0 * dot(N, V) * N - V;
  return kd_iso * anisoEnvDirectionAt(anisoEnvIrr, N) +
         scale * ks_iso * anisoEnvDirectionAt(anisoEnvGloss, R);
}
