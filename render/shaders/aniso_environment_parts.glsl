// aniso: light from an environment for a line material with maps (render/bake/environment.h
// EnvironmentParts), after aniso_environment.glsl (anisoEnvironmentCoord, anisoEnvLevels): D's and
// S's prefiltered terms apart, at unit k_d and k_s, so that a fragment applies its own k_d and k_s.
// anisoEnvPartD holds D's seven terms with their levels of b side by side in depth (term t's level
// i at layer t * levels + i); anisoEnvPartS S's the same way, with a map of n its levels of n one
// above the other (anisoEnvPartRows rows each; anisoEnvPartNLevels levels spaced
// anisoEnvPartLogStep in log n from anisoEnvPartLogN0), blended between the two either side of the
// fragment's log n. `aniso export --env` writes the volumes (tables/environment_parts_D.ktx2,
// _S.ktx2) and this file; `aniso preview --env` draws with it.
uniform sampler3D anisoEnvPartD;
uniform sampler3D anisoEnvPartS;
uniform float anisoEnvPartRows;
uniform int anisoEnvPartNLevels; uniform float anisoEnvPartLogN0; uniform float anisoEnvPartLogStep;

// D's and S's sums at unit k_d and k_s for N, the fiber T and V, at exponent n (which matters only
// where S holds levels of n).
void anisoEnvironmentParts(vec3 N, vec3 T, vec3 V, float n, out vec3 d, out vec3 s) {
  float w[7];
  vec3 st = anisoEnvironmentCoord(N, T, V, w);
  float levels = anisoEnvLevels, depth = 7.0 * anisoEnvLevels;
  float level = st.z * levels - 0.5;
  d = vec3(0.0);
  for (int t = 0; t < 7; ++t)
    d += w[t] * texture(anisoEnvPartD, vec3(st.xy, (float(t) * levels + level + 0.5) / depth)).rgb;
  int nl = anisoEnvPartNLevels;
  float f = nl > 1 && anisoEnvPartLogStep > 0.0
                ? clamp((log(max(n, 1e-6)) - anisoEnvPartLogN0) / anisoEnvPartLogStep, 0.0,
                        float(nl - 1))
                : 0.0;
  int k0 = min(int(f), max(nl - 2, 0));
  float wn = f - float(k0);
  // T's row within a level of n, held off the level's edges (as clamping to the edge would).
  float row = clamp(st.y * anisoEnvPartRows, 0.5, anisoEnvPartRows - 0.5);
  s = vec3(0.0);
  for (int r = 0; r < 2; ++r) {
    float wr = r == 0 ? 1.0 - wn : wn;
    if (wr <= 0.0) continue;
    vec2 sn = vec2(st.x, (float(k0 + r) * anisoEnvPartRows + row) / (anisoEnvPartRows * float(nl)));
    for (int t = 0; t < 7; ++t)
      s += wr * w[t] *
           texture(anisoEnvPartS, vec3(sn, (float(t) * levels + level + 0.5) / depth)).rgb;
  }
}
