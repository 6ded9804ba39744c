// aniso: the line-lighting model (Banks 1994; Heidrich & Seidel 1998) as a Unity Shader Graph
// Custom Function (File mode, function name AnisoLine). Inputs: the world normal, the world
// tangent turned by the fiber angle psi about the normal toward the bitangent (the export's
// FiberAngleDeg), the main light's direction (toward the light) and colour, the view direction
// (toward the viewer), k_d and k_s, and the two EXR tables as Bare Texture 2D with one Bare Sampler
// State (linear, clamp). Import the tables with sRGB off, compression none, mipmaps off.
// Radiance = LightColor (k_d D + k_s S) <N,L>+: URP's lights carry irradiance, so a light of
// intensity 1 gives what `aniso preview` gives for irradiance 1.
#ifndef ANISO_LINE_INCLUDED
#define ANISO_LINE_INCLUDED

// This material: Kd ({{KD}}), Ks ({{KS}}), FiberAngleDeg {{PSI}}.
#define ANISO_TEXELS {{TEXELS}}

float AnisoCoord(float c) {
  return (acos(clamp(-c, -1.0, 1.0)) / 3.14159265358979 * (ANISO_TEXELS - 1.0) + 0.5) /
         ANISO_TEXELS;
}

// Unity's importer puts a file's first row at v = 1: the tables' first stored row (<V,T> = -1)
// is read at 1 - t.
void AnisoLine_float(float3 Normal, float3 Tangent, float3 LightDirection, float3 LightColor,
                     float3 ViewDirection, float3 Kd, float3 Ks, Texture2D DiffuseTable,
                     Texture2D SpecularTable, SamplerState LinearClamp, out float3 Radiance) {
  float3 N = normalize(Normal);
  float3 T = normalize(Tangent - N * dot(N, Tangent));
  float2 uv = float2(AnisoCoord(dot(LightDirection, T)), 1.0 - AnisoCoord(dot(ViewDirection, T)));
  float D = DiffuseTable.SampleLevel(LinearClamp, uv, 0).r;
  float S = SpecularTable.SampleLevel(LinearClamp, uv, 0).r;
  Radiance = LightColor * (Kd * D + Ks * S) * max(dot(N, LightDirection), 0.0);
}

// The tangent turned by the fiber angle (degrees) about the normal toward the bitangent.
void AnisoFiberTangent_float(float3 Normal, float3 Tangent, float3 Bitangent, float FiberAngleDeg,
                             out float3 Fiber) {
  float psi = radians(FiberAngleDeg);
  Fiber = cos(psi) * Tangent + sin(psi) * Bitangent;
}

#endif
