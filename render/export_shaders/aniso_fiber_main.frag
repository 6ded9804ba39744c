// A complete fragment shader for the fiber model: one directional light, one topology s.
in vec3 vNormal;
in vec3 vFiber;  // the mesh tangent rotated by the fiber angle about the normal
uniform vec3 uLight;     // toward the light, same space as vNormal
uniform vec3 uView;      // toward the viewer
uniform vec3 uKd;
uniform vec3 uKs;
uniform vec3 uIrradiance;
uniform float uTopologyS;  // the material's s (a map of s: sample it here instead)
out vec4 fragColor;

void main() {
  vec3 N = normalize(vNormal);
  fragColor = vec4(anisoFiberRadiance(N, vFiber, normalize(uLight), normalize(uView), uTopologyS,
                                      uKd, uKs, uIrradiance), 1.0);
}
