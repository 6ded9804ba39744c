// A complete pixel shader for a material with maps: one directional light, the mesh tangent
// (turned by the material's fiber angle unless it has a map of the fiber direction) and the
// texture coordinates per vertex. A fiber material's (aniso_fiber.hlsli before aniso_maps.hlsli)
// draws the fiber model with one topology s.
cbuffer AnisoMaterial : register(b0) {
  float3 uLight;  // toward the light, same space as the normal
  float uTopologyS;  // the fiber model's s (unused by the line model)
  float3 uView;   // toward the viewer
  float pad1;
  float3 uKd;     // used where the material has no map of k_d
  float pad2;
  float3 uKs;     // used where the material has no map of k_s
  float pad3;
  float3 uIrradiance;
  float pad4;
};

struct PixelIn {
  float4 position : SV_Position;
  float3 normal : NORMAL;
  float3 fiber : TANGENT;  // the mesh tangent, turned by the fiber angle only without a fiber map
  float2 uv : TEXCOORD0;   // glTF TEXCOORD_0
};

float4 main(PixelIn i) : SV_Target {
  float3 N = normalize(i.normal);
#ifdef ANISO_NPHI
  return float4(anisoFiberRadianceMapped(N, i.fiber, i.uv, normalize(uLight), normalize(uView),
                                         uTopologyS, uKd, uKs, uIrradiance), 1.0);
#else
  return float4(anisoRadianceMapped(N, i.fiber, i.uv, normalize(uLight), normalize(uView), uKd,
                                    uKs, uIrradiance), 1.0);
#endif
}
