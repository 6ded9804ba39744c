// A complete pixel shader: one directional light, the fiber direction per vertex.
cbuffer AnisoMaterial : register(b0) {
  float3 uLight;  // toward the light, same space as the normal
  float pad0;
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
  return float4(anisoRadiance(N, i.fiber, normalize(uLight), normalize(uView), uKd, uKs,
                              uIrradiance), 1.0);
}
