#version 330 core
// The fiber model from its baked form (render/bake.h): the line tables through the paper's
// texture matrix times the factor tables G(phi_l, phi_v, s) and F(phi_l, phi_v, s, k), with the
// topology s per fragment from the mathematical topology and the topology map (docs/models.md §4).
// With a map of n (uMaps & 4) S_line comes from the specular stack (maps.glsl: stack_at) and F
// from uFStack, F's tables at levels over log n (render/bake.h: FiberStack; layer level * ns + s,
// the nk tables of phi side by side), each blended between the two levels either side of log n.
in vec3 vN; in vec3 vT; in vec3 vT2; in vec2 vUV;
uniform mat4 uTexMat;
uniform sampler2D uD;
uniform sampler2D uS;
uniform sampler2DArray uG;
uniform sampler2DArray uF;
uniform sampler2DArray uFStack; uniform int uFLevels; uniform float uFLogN0; uniform float uFLogStep;
uniform int uAngleIndex; uniform float uTexels;
uniform int uNphi; uniform int uNs; uniform int uNk;
uniform vec3 uL; uniform vec3 uV; uniform vec3 uE; uniform vec3 uKd; uniform vec3 uKs;
out vec4 frag;
// aniso: maps.glsl
// aniso: topology.glsl
const float PI = 3.14159265358979;
// A point light (uPointLight: at uLightPos, irradiance uE at distance uLightD0, falling off as
// 1/d^2) and a perspective viewer (uPerspective: at uEye) make L and V vary per fragment.
in vec3 vP;
uniform int uPointLight; uniform vec3 uLightPos; uniform float uLightD0;
uniform int uPerspective; uniform vec3 uEye;
void local_directions(out vec3 L, out vec3 V, out vec3 E) {
  L = uL; V = uV; E = uE;
  if (uPointLight == 1) {
    vec3 d = uLightPos - vP;
    float r = length(d);
    L = d / r;
    E = uE * (uLightD0 * uLightD0) / (r * r);
  }
  if (uPerspective == 1) V = normalize(uEye - vP);
}
void main() {
  vec3 L, V, E;
  local_directions(L, V, E);
  vec3 N = normalize(vN);
  vec3 T = turned_by_map(normalize(vT - N * dot(N, vT)), N);
  vec3 B = cross(N, T);
  float ln = dot(L, N), vn = dot(V, N);
  if (ln <= 0.0 || vn <= 0.0) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
  vec2 st = (uTexMat * vec4(T, 1.0)).xy;
  if (uPointLight == 1 || uPerspective == 1) {  // the texture matrix's job, per fragment
    st = 0.5 + 0.5 * vec2(dot(L, T), dot(V, T));
    if (uAngleIndex == 0) st = st * (uTexels - 1.0) / uTexels + 0.5 / uTexels;
  }
  if (uAngleIndex == 1) st = (acos(clamp(1.0 - 2.0 * st, -1.0, 1.0)) / PI * (uTexels - 1.0) + 0.5) / uTexels;
  bool nmap = (uMaps & 4) != 0;
  float n = nmap ? map_at(uNMap, vUV).r : 0.0;
  float Dl = texture(uD, st).r, Sl = nmap ? stack_at(st, n) : texture(uS, st).r;
  float a = dot(L, T), b = dot(V, T), lb = dot(L, B), vb = dot(V, B);
  float sL = length(vec2(lb, ln)), sV = length(vec2(vb, vn));
  float g0 = sL * sV - a * b;
  float kk = g0 > 0.0 ? 2.0 * sL * sV / (g0 + 2.0 * sL * sV) : 1.0;
  float s = topology_at();
  vec2 uvphi = ((vec2(atan(lb, ln), atan(vb, vn)) + 0.5 * PI) / PI * float(uNphi - 1) + 0.5) / float(uNphi);
  float fs = clamp(s, 0.0, 1.0) * float(uNs - 1);
  int is = min(int(fs), uNs - 2);
  float ws = fs - float(is);
  float fk = kk * float(uNk - 1);
  int ik = min(int(fk), uNk - 2);
  float wk = fk - float(ik);
  float G = mix(texture(uG, vec3(uvphi, float(is))).r, texture(uG, vec3(uvphi, float(is + 1))).r, ws);
  float F;
  if (nmap) {
    float f = uFLogStep > 0.0 ? clamp((log(n) - uFLogN0) / uFLogStep, 0.0, float(uFLevels - 1)) : 0.0;
    float k0 = min(floor(f), float(uFLevels - 2));
    float Fl[2];
    for (int l = 0; l < 2; ++l) {  // the two levels' F, each multi-linear in (s, k) as below
      float layer = (k0 + float(l)) * float(uNs) + float(is);
      vec2 a = vec2((float(ik) + uvphi.x) / float(uNk), uvphi.y), b = a + vec2(1.0 / float(uNk), 0.0);
      float f0 = mix(texture(uFStack, vec3(a, layer)).r, texture(uFStack, vec3(b, layer)).r, wk);
      float f1 = mix(texture(uFStack, vec3(a, layer + 1.0)).r, texture(uFStack, vec3(b, layer + 1.0)).r, wk);
      Fl[l] = mix(f0, f1, ws);
    }
    F = Fl[0] + (f - k0) * (Fl[1] - Fl[0]);
  } else {
    float F0 = mix(texture(uF, vec3(uvphi, float(is * uNk + ik))).r, texture(uF, vec3(uvphi, float(is * uNk + ik + 1))).r, wk);
    float F1 = mix(texture(uF, vec3(uvphi, float((is + 1) * uNk + ik))).r,
                   texture(uF, vec3(uvphi, float((is + 1) * uNk + ik + 1))).r, wk);
    F = mix(F0, F1, ws);
  }
  frag = vec4(E * (map_or(1, uKdMap, uKd) * Dl * G + map_or(2, uKsMap, uKs) * Sl * F), 1.0);
}
