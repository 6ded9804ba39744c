// A complete pixel shader for the fiber model: one directional light, one topology s.
cbuffer AnisoMaterial : register(b0) {
  float3 uLight;  // toward the light, same space as the normal
  float uTopologyS;  // the material's s (a map of s: sample it here instead)
  float3 uView;   // toward the viewer
  float pad1;
  float3 uKd;
  float pad2;
  float3 uKs;
  float pad3;
  float3 uIrradiance;
  float pad4;
};

struct PixelIn {
  float4 position : SV_Position;
  float3 normal : NORMAL;
  float3 fiber : TANGENT;  // the mesh tangent rotated by the fiber angle about the normal
};

float4 main(PixelIn i) : SV_Target {
  float3 N = normalize(i.normal);
  return float4(anisoFiberRadiance(N, i.fiber, normalize(uLight), normalize(uView), uTopologyS,
                                   uKd, uKs, uIrradiance), 1.0);
}
