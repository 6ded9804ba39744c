#version 330 core
// The fiber model under an environment (render/bake/environment_fiber.h) through
// aniso_environment_fiber.glsl, the exported shader: maps of k_d, k_s and the fiber direction apply
// per fragment (maps.glsl), the topology s as the fiber pass takes it (topology.glsl); a second
// fiber reads the same tables at T2, the isotropic term its own (environment_isotropic.glsl).
in vec3 vN; in vec3 vT; in vec3 vP; in vec2 vUV;
uniform vec3 uV; uniform int uPerspective; uniform vec3 uEye;
uniform vec3 uEnvKd; uniform vec3 uEnvKs;
out vec4 frag;
// aniso: maps.glsl
// aniso: topology.glsl
// aniso: aniso_environment_isotropic.glsl
// aniso: environment_isotropic.glsl
// aniso: aniso_environment_fiber.glsl
void main() {
  vec3 N = normalize(vN);
  vec3 V = uPerspective == 1 ? normalize(uEye - vP) : uV;
  vec3 iso = isotropic_environment(N, V);
  if (dot(N, V) <= 0.0) {
    frag = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  float topo = topology_at();
  float n = (uMaps & 4) != 0 ? map_at(uNMap, vUV).r : 1.0;  // (one level of n without its map)
  vec3 d, s;
  anisoFiberEnvironmentParts(N, turned_by_map(normalize(vT - N * dot(N, vT)), N), V, topo, n, d, s);
  if (uEnvSecond == 1) {
    vec3 d2, s2;
    anisoFiberEnvironmentParts(N, normalize(vT2 - N * dot(N, vT2)), V, topo, n, d2, s2);
    d = uEnvW * d + (1.0 - uEnvW) * d2;
    s = uEnvW * s + (1.0 - uEnvW) * s2;
  }
  vec3 kd = map_or(1, uKdMap, uEnvKd), ks = map_or(2, uKsMap, uEnvKs);
  frag = vec4(max(kd * d + ks * s, vec3(0.0)) + iso, 1.0);
}
