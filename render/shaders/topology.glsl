// The fiber model's topology s at the fragment (models/topology.h s_at), spliced into fiber.frag
// and env_fiber.frag after maps.glsl: one branch per source (uTopo 0: one s for the surface,
// 1: the shape's mathematical topology, 2: that plus a topology map with its amplitude (or a map
// of the amplitude: uMaps & 16), 3: a map of s itself, in uMap).
uniform sampler2D uMap;
uniform int uTopo;
uniform float uS0; uniform float uAmp;
in float vSmath;
float topology_at() {
  if (uTopo == 0) return uS0;
  if (uTopo == 1) return vSmath;
  if (uTopo == 3) return texture(uMap, vUV).r;
  float m = 2.0 * texture(uMap, vUV).r - 1.0;
  float amp = (uMaps & 16) != 0 ? map_at(uAmpMap, vUV).r : uAmp;
  float H = clamp(2.0 * sin(3.14159265358979 / 3.0 * vSmath) + amp * m, 0.0, sqrt(3.0));
  return asin(0.5 * H) / (3.14159265358979 / 3.0);
}
