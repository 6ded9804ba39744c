// aniso: the line-lighting model (Banks 1994; Heidrich & Seidel 1998), an Unreal Custom node's
// body (Output Type Float 3). Inputs: N, T (the tangent turned by the fiber angle psi about the
// normal), L (toward the light), V (toward the viewer), E (the light's irradiance), Kd, Ks, and
// DiffuseTable, SpecularTable as Texture Object inputs (EXR tables imported as HDR, sRGB off,
// no mips, clamp). The tables' first stored row (<V,T> = -1) is Unreal's V = 0: no flip.
const float Texels = {{TEXELS}};
float3 Tf = normalize(T - N * dot(N, T));
float2 uv = (acos(clamp(-float2(dot(L, Tf), dot(V, Tf)), -1.0, 1.0)) / 3.14159265358979 *
             (Texels - 1.0) + 0.5) / Texels;
float D = Texture2DSampleLevel(DiffuseTable, DiffuseTableSampler, uv, 0).r;
float S = Texture2DSampleLevel(SpecularTable, SpecularTableSampler, uv, 0).r;
return E * (Kd * D + Ks * S) * max(dot(N, L), 0.0);
