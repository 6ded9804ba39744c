// aniso: the line-lighting model (Banks 1994; Heidrich & Seidel 1998) from the exported tables.
// Include after `#version` and a `#define ANISO_TEXELS N` (the export writes both).
//   tables/diffuse.ktx2, tables/specular.ktx2: N x N, R32F, linear values, no sRGB;
//   s (x) = <L,T>, t (y) = <V,T>, texel i at the angle acos(-c) = pi i / (N - 1);
//   sample with GL_LINEAR and GL_CLAMP_TO_EDGE, no mipmaps.
// T is the fiber direction (tangent rotated by the material's fiber angle); <N,L>^+ is applied
// here, per fragment, not baked.
uniform sampler2D anisoDiffuse;
uniform sampler2D anisoSpecular;

float anisoCoord(float c) {
  const float PI = 3.14159265358979;
  return (acos(clamp(-c, -1.0, 1.0)) / PI * (ANISO_TEXELS - 1.0) + 0.5) / ANISO_TEXELS;
}

// Radiance toward V from one light of irradiance E along L (all unit vectors, one space).
vec3 anisoRadiance(vec3 N, vec3 T, vec3 L, vec3 V, vec3 kd, vec3 ks, vec3 E) {
  T = normalize(T - N * dot(N, T));
  vec2 st = vec2(anisoCoord(dot(L, T)), anisoCoord(dot(V, T)));
  float D = texture(anisoDiffuse, st).r;
  float S = texture(anisoSpecular, st).r;
  return E * (kd * D + ks * S) * max(dot(N, L), 0.0);
}
