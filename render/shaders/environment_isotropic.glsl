// The isotropic term and a second fiber under an environment, spliced into env.frag and
// env_fiber.frag: the irradiance over N and the Phong lobe over V's mirror direction R
// (render/bake/environment.h IsotropicEnvironment), read as equirectangular tables (z up).
uniform int uEnvIso; uniform vec3 uEnvKdIso; uniform vec3 uEnvKsIso;
uniform sampler3D uEnvIrr; uniform sampler3D uEnvGloss;
uniform float uEnvIsoScale[33];  // the glossy table's factor at <N,V> = i / 32
uniform int uEnvSecond; uniform float uEnvW;  // a second fiber: w for the first lobe, 1 - w for it
in vec3 vT2;
vec3 env_direction_at(sampler3D table, vec3 D) {
  const float PI = 3.14159265358979;
  float phi = atan(D.y, D.x);
  return texture(table, vec3(phi / (2.0 * PI) + (phi < 0.0 ? 1.0 : 0.0),
                             acos(clamp(D.z, -1.0, 1.0)) / PI, 0.5)).rgb;
}
vec3 isotropic_environment(vec3 N, vec3 V) {
  if (uEnvIso == 0) return vec3(0.0);
  float nv = clamp(dot(N, V), 0.0, 1.0) * 32.0;
  int i = min(int(nv), 31);
  float scale = mix(uEnvIsoScale[i], uEnvIsoScale[i + 1], nv - float(i));
  vec3 R = 2.0 * dot(N, V) * N - V;
  return uEnvKdIso * env_direction_at(uEnvIrr, N) +
         scale * uEnvKsIso * env_direction_at(uEnvGloss, R);
}
