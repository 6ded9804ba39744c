// A complete fragment shader for a material with maps: one directional light, the mesh tangent
// (turned by the material's fiber angle unless it has a map of the fiber direction) and the
// texture coordinates per vertex. A fiber material's (aniso_fiber.glsl before aniso_maps.glsl)
// draws the fiber model with one topology s.
in vec3 vNormal;
in vec3 vFiber;  // the mesh tangent, turned by the fiber angle only without a fiber map
in vec2 vUV;     // glTF TEXCOORD_0
uniform vec3 uLight;     // toward the light, same space as vNormal
uniform vec3 uView;      // toward the viewer
uniform vec3 uKd;        // used where the material has no map of k_d
uniform vec3 uKs;        // used where the material has no map of k_s
uniform vec3 uIrradiance;
#ifdef ANISO_NPHI
uniform float uTopologyS;  // the fiber model's s
#endif
out vec4 fragColor;

void main() {
  vec3 N = normalize(vNormal);
#ifdef ANISO_NPHI
  fragColor = vec4(anisoFiberRadianceMapped(N, vFiber, vUV, normalize(uLight), normalize(uView),
                                            uTopologyS, uKd, uKs, uIrradiance), 1.0);
#else
  fragColor = vec4(anisoRadianceMapped(N, vFiber, vUV, normalize(uLight), normalize(uView), uKd,
                                       uKs, uIrradiance), 1.0);
#endif
}
