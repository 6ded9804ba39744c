// The optional terms under an environment in the preview's passes (env.frag, env_fiber.frag): the
// isotropic term through aniso_environment_isotropic.glsl (uEnvIso: the material has one), and a
// second fiber's weight (uEnvSecond: w for the first lobe, 1 - w for the one along vT2).
uniform int uEnvIso; uniform vec3 uEnvKdIso; uniform vec3 uEnvKsIso;
uniform int uEnvSecond; uniform float uEnvW;
in vec3 vT2;
vec3 isotropic_environment(vec3 N, vec3 V) {
  return uEnvIso == 0 ? vec3(0.0) : anisoIsotropicEnvironment(N, V, uEnvKdIso, uEnvKsIso);
}
