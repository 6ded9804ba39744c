#include "render/preview/preview.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "core/angles.h"
#include "core/error.h"
#include "geometry/topology.h"
#include "io/files/files.h"
#include "render/bake/environment_fiber.h"
#include "render/preview/gl.h"
#include "render/preview/preview_reference.h"
#include "render/shaders_embedded.h"

namespace aniso {

namespace {

// Vertex attributes: P, N, T, T2 (3 each), uv (2), s_math (1); see render/shaders/vertex.vert.
const std::vector<int> kAttributeSizes = {3, 3, 3, 3, 2, 1};

// Brute force sums the exact model over the environment at twice the prefilter's resolution
// in each direction (128 x 64 directions).
constexpr int kEnvironmentReferenceW = 128;

// Whether the passes draw the material's maps (render/shaders/maps.glsl): every pass but the plain
// one. With a map of n the fiber pass takes S_line and F from stacks over n (render/bake/bake.h).
bool drawn_maps(const Material& m, const PreviewOptions& opt) { return !opt.plain && m.maps.any(); }

// Per-vertex fiber directions T and T2 (docs/models.md §1), uv and the mathematical topology.
// With a map of the fiber direction T is the reference tangent U: the shader turns it by the map's
// angle per fragment.
std::vector<float> vertex_attributes(const Material& m, const PreviewOptions& opt,
                                     const TriMesh& mesh, double* radius) {
  const bool psi_map = drawn_maps(m, opt) && m.maps.fiber;
  const double psi = psi_map ? 0.0 : deg_to_rad(m.fiber_angle_deg),
               psi2 = deg_to_rad(m.second_angle_deg);
  std::vector<float> vbuf;
  *radius = 0;
  for (size_t i = 0; i < mesh.P.size(); ++i) {
    const Vec3 N = normalize(mesh.N[i]);
    const Vec3 U =
        fiber_field_tangent(opt.fiber_field, mesh.P[i], N, mesh.U[i], mesh.center, mesh.axis);
    const Vec3 W = cross(N, U);
    const Vec3 T = U * std::cos(psi) + W * std::sin(psi),
               T2 = U * std::cos(psi2) + W * std::sin(psi2);
    for (const Vec3& v : {mesh.P[i], N, T, T2}) {
      vbuf.push_back(float(v.x));
      vbuf.push_back(float(v.y));
      vbuf.push_back(float(v.z));
    }
    vbuf.push_back(mesh.uv[i][0]);
    vbuf.push_back(mesh.uv[i][1]);
    vbuf.push_back(float(mathematical_topology_at(m.mathematical(), mesh.P[i], opt.shape_options)));
    *radius = std::max(*radius, length(mesh.P[i] - mesh.center));
  }
  return vbuf;
}

// Orthographic camera looking along -V (a distant viewer: V constant, as in the paper), framing
// a sphere of `radius` about `c` with 10 % margin. Row-major.
void ortho_view_proj(const Vec3& V, const Vec3& c, double radius, double aspect, float out[16]) {
  Vec3 right = cross(Vec3(0, 0, 1), V);
  if (length(right) < 1e-6) right = Vec3(1, 0, 0);
  right = normalize(right);
  const Vec3 up = cross(V, right);
  const double ext = 1.1 * radius, ex = ext * aspect;
  const double m[16] = {right.x / ex,
                        right.y / ex,
                        right.z / ex,
                        -dot(right, c) / ex,
                        up.x / ext,
                        up.y / ext,
                        up.z / ext,
                        -dot(up, c) / ext,
                        -V.x / (2 * ext),
                        -V.y / (2 * ext),
                        -V.z / (2 * ext),
                        dot(V, c) / (2 * ext),
                        0,
                        0,
                        0,
                        1};
  for (int i = 0; i < 16; ++i) out[i] = float(m[i]);
}

// A viewer at a finite distance: 30 degree vertical field of view framing a sphere of `radius`
// (with 10 % margin) about `c`, from the direction V. Row-major; eye returned.
Vec3 perspective_view_proj(const Vec3& V, const Vec3& c, double radius, double aspect,
                           float out[16]) {
  constexpr double kFovY = 30.0;
  const double half = deg_to_rad(kFovY / 2), ext = 1.1 * radius;
  const double dist = ext / std::sin(half) / std::min(1.0, aspect);
  const Vec3 eye = c + V * dist;
  Vec3 right = cross(Vec3(0, 0, 1), V);
  if (length(right) < 1e-6) right = Vec3(1, 0, 0);
  right = normalize(right);
  const Vec3 up = cross(V, right);
  const double f = 1.0 / std::tan(half), n = std::max(dist - 2 * ext, 1e-3 * dist),
               fa = dist + 2 * ext;
  // Projection times the view matrix (rows right, up, V; eye at the origin).
  const double a = (fa + n) / (n - fa), b = 2 * fa * n / (n - fa);
  const Vec3 rows[3] = {right * (f / aspect), up * f, V * a};
  const double m[16] = {rows[0].x, rows[0].y, rows[0].z, -dot(rows[0], eye),
                        rows[1].x, rows[1].y, rows[1].z, -dot(rows[1], eye),
                        rows[2].x, rows[2].y, rows[2].z, -dot(rows[2], eye) + b,
                        -V.x,      -V.y,      -V.z,      dot(V, eye)};
  for (int i = 0; i < 16; ++i) out[i] = float(m[i]);
  return eye;
}

// The paper's texture matrix: (T, 1) -> ((<L,T> + 1) / 2, (<V,T> + 1) / 2), with the cosine
// index's texel-centre remap folded in. Row-major.
void texture_matrix(const Vec3& L, const Vec3& V, const BakeTables& t, float out[16]) {
  const bool angle = t.index == BakeIndex::kAngle;
  const double k = angle ? 1.0 : (t.size - 1.0) / t.size, o = angle ? 0.0 : 0.5 / t.size;
  const double m[16] = {k * L.x / 2, k * L.y / 2, k * L.z / 2, k / 2 + o, k * V.x / 2, k * V.y / 2,
                        k * V.z / 2, k / 2 + o,   0,           0,         0,           0,
                        0,           0,           0,           1};
  for (int i = 0; i < 16; ++i) out[i] = float(m[i]);
}

// A pass's fragment shader with the parts it names spliced in where it says so
// (render/shaders/maps.glsl, aniso_environment.glsl).
std::string with_maps(const char* frag) {
  std::string s = frag;
  for (const auto& [marker, part] :
       {std::pair<std::string, const char*>{"// aniso: maps.glsl", shaders::maps_glsl},
        {"// aniso: topology.glsl", shaders::topology_glsl},
        {"// aniso: environment_isotropic.glsl", shaders::environment_isotropic_glsl},
        {"// aniso: aniso_environment_isotropic.glsl", shaders::aniso_environment_isotropic_glsl},
        {"// aniso: aniso_environment_fiber.glsl", shaders::aniso_environment_fiber_glsl},
        {"// aniso: aniso_environment_parts.glsl", shaders::aniso_environment_parts_glsl},
        {"// aniso: aniso_environment.glsl", shaders::aniso_environment_glsl}})
    if (const size_t at = s.find(marker); at != std::string::npos)
      s.replace(at, marker.size(), part);
  return s;
}

// What the passes sample: the line tables, and for the fiber model its factor tables and the
// material's topology map; with maps also the maps themselves (read texel by texel) and, with a
// map of n, the specular tables over its range (and the fiber model's F over it).
struct Lookups {
  BakeTables tables;
  FiberBakeTables fb;
  gl::Texture D, S, G, F, map;
  bool maps = false;
  SpecularStack stack;
  FiberStack fstack;  // the fiber model with a map of n
  gl::Texture kd_map, ks_map, n_map, fiber_map, s_stack, amp_map, f_stack;
};

// An environment's prefiltered terms as RGB volumes; for a material with maps, apart for D and S
// at unit k_d and k_s (`spec` then holds S's); for the fiber model its three volumes
// (render/shaders/env_fiber.frag).
struct EnvironmentLookup {
  gl::Texture terms[7], part_d, part_s;
  bool parts = false;
  int levels = 0;
  bool fiber = false;
  gl::Texture fiber_d, fiber_s, fiber_coef;
  int order = 0, phis = 0, s_levels = 1;
  int n_levels = 1;  // a map of n: S's terms at levels of n (spaced log_step in log n)
  int rows = 0;      // the rows of a level of n in S's volume
  double logn0 = 0, log_step = 0;
  bool iso = false;  // the isotropic term's irradiance and glossy tables
  gl::Texture iso_irr, iso_gloss;
  float iso_scale[IsotropicEnvironment::kScaleNodes] = {};
};

// A fiber material's tables as the volumes env_fiber.frag reads: D's terms as layers, S's terms
// with their levels side by side, the coefficients three to a layer over (phi_v, b).
void fiber_environment_volumes(const FiberEnvironmentTables& t, EnvironmentLookup* env) {
  const int nt = t.terms();
  env->fiber_d.volume_rgb(t.diffuse, t.w, t.h, nt);
  env->fiber_s.volume_rgb(fiber_environment_specular_volume(t), t.w, t.h * t.nn, nt * t.nb);
  env->fiber_coef.volume_rgb(fiber_environment_coef_volume(t), t.nphi, t.nb,
                             t.coef_layers() * t.ns * t.nn);
  env->n_levels = t.nn;
  env->rows = t.h;
  env->logn0 = t.logn0, env->log_step = t.log_step;
  env->fiber = true;
  env->levels = t.nb;
  env->order = t.order;
  env->phis = t.nphi;
  env->s_levels = t.ns;
}

// The environment's units: after the maps' (5 to 10), the whole's seven terms (or the fiber
// model's three volumes), a maps material's two volumes of D and S, the isotropic term's two
// tables.
constexpr int kEnvUnit = 11, kEnvSpecUnit = 18, kEnvIsoUnit = 25;

// A map of k_d or k_s as RGB (one channel stands for all three, as material_at reads it).
Image as_rgb(const Image& img) {
  if (img.channels >= 3) return img;
  Image out(img.width, img.height, 3);
  for (size_t p = 0; p < static_cast<size_t>(img.width) * img.height; ++p)
    for (int c = 0; c < 3; ++c) out.px[p * 3 + c] = img.px[p * img.channels];
  return out;
}

void make_map_lookups(const Material& m, const PreviewOptions& opt, Lookups* lk) {
  const SpecularStack* baked = opt.baked_stack;
  const MaterialMaps& mp = m.maps;
  lk->maps = true;
  if (mp.kd) lk->kd_map.texels(as_rgb(*mp.kd));
  if (mp.ks) lk->ks_map.texels(as_rgb(*mp.ks));
  if (mp.fiber) lk->fiber_map.texels(*mp.fiber);
  if (mp.amplitude) lk->amp_map.texels(*mp.amplitude);
  if (m.fiber() && !mp.n) return;
  lk->stack = baked && mp.n ? *baked : bake_material_stack(m, lk->tables.size, lk->tables.index);
  if (!mp.n) return;
  lk->n_map.texels(*mp.n);
  lk->s_stack.array(stack_levels(lk->stack), lk->stack.size, lk->stack.size, lk->stack.levels);
  if (!m.fiber()) return;
  lk->fstack = opt.baked_fiber_stack
                   ? *opt.baked_fiber_stack
                   : bake_fiber_stack(m, lk->fb, lk->tables, lk->stack, 0.2, 28, 1, opt.progress);
  lk->f_stack.array(fiber_stack_layers(lk->fb, lk->fstack), lk->fb.nk * lk->fb.nphi, lk->fb.nphi,
                    lk->fstack.levels * lk->fb.ns);
}

// The passes' map uniforms (render/shaders/maps.glsl), units 5 to 10. Each sampler gets its own
// unit even without maps: samplers of two types on one unit (the default 0) fail the draw.
void set_map_uniforms(const gl::Program& p, const Material& m, const Lookups& lk) {
  const MaterialMaps& mp = m.maps;
  const bool line = !m.fiber();
  const int bits = lk.maps ? (mp.kd ? 1 : 0) | (mp.ks ? 2 : 0) | (mp.n ? 4 : 0) |
                                 (mp.fiber ? 8 : 0) | (mp.amplitude && !line ? 16 : 0)
                           : 0;
  p.set("uMaps", bits);
  const std::pair<const gl::Texture*, const char*> units[6] = {
      {&lk.kd_map, "uKdMap"},       {&lk.ks_map, "uKsMap"},   {&lk.n_map, "uNMap"},
      {&lk.fiber_map, "uFiberMap"}, {&lk.s_stack, "uSStack"}, {&lk.amp_map, "uAmpMap"}};
  for (int k = 0; k < 6; ++k) {
    if (!units[k].first->empty()) units[k].first->bind(5 + k);
    p.set(units[k].second, 5 + k);
  }
  if (!bits) return;
  p.set("uRepeat", mp.repeat ? 1 : 0);
  p.set("uLevels", lk.stack.levels);
  p.set("uLogN0", float(lk.stack.logn0));
  p.set("uLogStep", float(lk.stack.log_step()));
}

void make_lookups(const Material& m, const PreviewOptions& opt, bool fiber, bool paper,
                  Lookups* lk) {
  const BakeIndex index = opt.baked                        ? opt.baked->index
                          : opt.table_index == 1 && !paper ? BakeIndex::kAngle
                                                           : BakeIndex::kCosine;
  if (paper && index != BakeIndex::kCosine)
    throw Error("preview: --per-vertex (the paper's construction) needs a cosine-index bake");
  lk->tables = opt.baked ? *opt.baked : bake_line(m, opt.table_size, index);
  lk->D.table(lk->tables.diffuse);
  lk->S.table(lk->tables.specular);
  if (fiber) {  // before the maps: a map of n stacks F on the same grid
    lk->fb =
        opt.baked_fiber ? *opt.baked_fiber : bake_fiber(m, lk->tables, 64, 9, 16, 1, opt.progress);
    lk->G.array(lk->fb.G, lk->fb.nphi, lk->fb.nphi, lk->fb.ns);
    lk->F.array(lk->fb.F, lk->fb.nphi, lk->fb.nphi, lk->fb.ns * lk->fb.nk);
  }
  if (drawn_maps(m, opt) && !paper) make_map_lookups(m, opt, lk);
  if (!fiber) return;
  if (m.topology_as<SMapRef>())
    lk->map.map(opt.s_map);
  else if (m.topology_as<TopologyMapRef>())
    lk->map.map(opt.topology_map);
}

// The uniforms of the shaders' copy of s_at (models/topology.h, render/shaders/topology.glsl),
// one branch per topology source.
void set_topology_uniforms(const gl::Program& p, const Material& m, const Lookups& lk) {
  if (!lk.map.empty()) lk.map.bind(4);
  p.set("uMap", 4);
  const auto* map_ref = m.topology_as<TopologyMapRef>();
  const int topo = m.topology_as<SMapRef>()         ? 3
                   : map_ref                        ? 2
                   : m.topology_as<MathematicalS>() ? 1
                                                    : 0;
  p.set("uTopo", topo);
  p.set("uS0", float(m.uniform_s()));
  p.set("uAmp", float(map_ref ? map_ref->amplitude : 0.0));
}

// The fiber pass's own uniforms: its tables and the topology's.
void set_fiber_uniforms(const gl::Program& p, const Material& m, const Lookups& lk, const Vec3& V) {
  lk.G.bind(2);
  lk.F.bind(3);
  if (!lk.f_stack.empty()) lk.f_stack.bind(11);  // after the maps' units 5 to 10
  p.set("uG", 2);
  p.set("uF", 3);
  p.set("uFStack", 11);
  p.set("uFLevels", lk.fstack.levels);
  p.set("uFLogN0", float(lk.fstack.logn0));
  p.set("uFLogStep", float(lk.fstack.log_step()));
  p.set("uNphi", lk.fb.nphi);
  p.set("uNs", lk.fb.ns);
  p.set("uNk", lk.fb.nk);
  set_topology_uniforms(p, m, lk);
  p.set("uV", V);
}

struct Passes {
  std::unique_ptr<gl::Program> aniso, iso;
  bool fiber = false;
};

// One frame: per light, one additive pass per fiber lobe and one for the isotropic term.
// Per-fragment directions (render/shaders: local_directions) for a point light and a finite
// viewer.
void set_local_uniforms(const gl::Program& p, const PreviewLight& light, const PreviewCamera& cam) {
  p.set("uPointLight", light.point ? 1 : 0);
  p.set("uLightPos", light.pos);
  p.set("uLightD0", float(light.d0));
  p.set("uPerspective", cam.perspective ? 1 : 0);
  p.set("uEye", cam.eye);
}

// Light from an environment: one pass over its prefiltered tables (render/shaders/env.frag).
int draw_environment(const Material& m, const PreviewOptions& opt, const gl::Program& p,
                     const EnvironmentLookup& env, const Lookups& lk, const gl::MeshBuffers& mesh,
                     const PreviewCamera& cam) {
  glClearColor(float(opt.background[0]), float(opt.background[1]), float(opt.background[2]), 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_BLEND);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  p.use();
  p.set_matrix("uViewProj", cam.view_proj);
  p.set("uEnvKd", m.kd);
  p.set("uEnvKs", m.ks);
  p.set("uV", cam.V);
  p.set("uPerspective", cam.perspective ? 1 : 0);
  p.set("uEye", cam.eye);
  p.set("uEnvSecond", m.second_active() ? 1 : 0);
  p.set("uEnvW", float(m.second_weight));
  p.set("uEnvIso", env.iso ? 1 : 0);
  p.set("uEnvKdIso", m.iso_kd);
  p.set("uEnvKsIso", m.iso_ks);
  if (env.iso) {
    env.iso_irr.bind(kEnvIsoUnit);
    env.iso_gloss.bind(kEnvIsoUnit + 1);
    glUniform1fv(glGetUniformLocation(p.id(), "anisoEnvIsoScale"),
                 IsotropicEnvironment::kScaleNodes, env.iso_scale);
  }
  p.set("anisoEnvIrr", kEnvIsoUnit);
  p.set("anisoEnvGloss", kEnvIsoUnit + 1);
  if (env.fiber) {
    env.fiber_d.bind(kEnvUnit);
    env.fiber_s.bind(kEnvUnit + 1);
    env.fiber_coef.bind(kEnvUnit + 2);
    p.set("anisoFibEnvD", kEnvUnit);
    p.set("anisoFibEnvS", kEnvUnit + 1);
    p.set("anisoFibEnvCoef", kEnvUnit + 2);
    p.set("anisoFibEnvOrder", env.order);
    p.set("anisoFibEnvLevels", float(env.levels));
    p.set("anisoFibEnvPhis", float(env.phis));
    p.set("anisoFibEnvSLevels", env.s_levels);
    p.set("anisoFibEnvNLevels", env.n_levels);
    p.set("anisoFibEnvRows", float(env.rows));
    p.set("anisoFibEnvLogN0", float(env.logn0));
    p.set("anisoFibEnvLogStep", float(env.log_step));
    set_map_uniforms(p, m, lk);
    set_topology_uniforms(p, m, lk);
    mesh.draw();
    glFinish();
    return 1;
  }
  for (int t = 0; t < 7; ++t) {
    if (!env.parts) env.terms[t].bind(kEnvUnit + t);
    p.set(("anisoEnv[" + std::to_string(t) + "]").c_str(), kEnvUnit + t);
  }
  if (env.parts) {
    env.part_d.bind(kEnvSpecUnit);
    env.part_s.bind(kEnvSpecUnit + 1);
  }
  p.set("anisoEnvPartD", kEnvSpecUnit);
  p.set("anisoEnvPartS", kEnvSpecUnit + 1);
  set_map_uniforms(p, m, lk);
  p.set("uEnvParts", env.parts ? 1 : 0);
  p.set("anisoEnvPartRows", float(env.rows));
  p.set("anisoEnvPartNLevels", env.n_levels);
  p.set("anisoEnvPartLogN0", float(env.logn0));
  p.set("anisoEnvPartLogStep", float(env.log_step));
  p.set("anisoEnvLevels", float(env.levels));
  mesh.draw();
  glFinish();
  return 1;
}

int draw_frame(const Material& m, const PreviewOptions& opt, const Passes& ps, const Lookups& lk,
               const gl::MeshBuffers& mesh, const PreviewCamera& cam,
               const std::vector<PreviewLight>& lights) {
  const float* view_proj = cam.view_proj;
  const Vec3& V = cam.V;
  glClearColor(float(opt.background[0]), float(opt.background[1]), float(opt.background[2]), 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_BLEND);
  glDepthFunc(GL_LESS);
  glDepthMask(GL_TRUE);
  int passes = 0;
  auto begin_pass = [&]() {
    if (passes == 1) {  // every pass after the first adds onto the image
      glEnable(GL_BLEND);
      glBlendFunc(GL_ONE, GL_ONE);
      glDepthFunc(GL_LEQUAL);
      glDepthMask(GL_FALSE);
    }
    ++passes;
  };
  const gl::Program& pa = *ps.aniso;
  for (const PreviewLight& light : lights) {
    const Vec3& L = light.dir;
    const Vec3 E(light.irradiance, light.irradiance, light.irradiance);
    float texmat[16];
    texture_matrix(L, V, lk.tables, texmat);
    const int lobes = m.second_active() && !opt.plain && !ps.fiber ? 2 : 1;
    for (int lobe = 0; lobe < lobes; ++lobe) {
      begin_pass();
      pa.use();
      if (ps.fiber) set_fiber_uniforms(pa, m, lk, V);
      if (!opt.plain) set_map_uniforms(pa, m, lk);
      pa.set_matrix("uViewProj", view_proj);
      pa.set_matrix("uTexMat", texmat);
      lk.D.bind(0);
      lk.S.bind(1);
      pa.set("uD", 0);
      pa.set("uS", 1);
      pa.set("uL", L);
      pa.set("uV", V);
      set_local_uniforms(pa, light, cam);
      pa.set("uE", E);
      pa.set("uKd", m.kd);
      pa.set("uKs", m.ks);
      const double wgt =
          m.second_active() ? (lobe == 0 ? m.second_weight : 1 - m.second_weight) : 1.0;
      pa.set("uWeight", float(wgt));
      pa.set("uUseT2", lobe);
      pa.set("uAngleIndex", lk.tables.index == BakeIndex::kAngle ? 1 : 0);
      pa.set("uTexels", float(lk.tables.size));
      mesh.draw();
    }
    if (m.isotropic_active() && !opt.plain) {
      begin_pass();
      ps.iso->use();
      ps.iso->set_matrix("uViewProj", view_proj);
      ps.iso->set("uL", L);
      ps.iso->set("uV", V);
      set_local_uniforms(*ps.iso, light, cam);
      ps.iso->set("uE", E);
      ps.iso->set("uKd", m.iso_kd);
      ps.iso->set("uKs", m.iso_ks);
      ps.iso->set("uN", float(m.iso_n));
      mesh.draw();
    }
  }
  glFinish();
  return passes;
}

// The geometry pass: N, T and T2 (or u, v, s_math) per fragment, and which pixels are covered.
GBuffer geometry_pass(const gl::Framebuffer& fb, const gl::MeshBuffers& mesh,
                      const float view_proj[16], bool fiber, PreviewResult* res) {
  constexpr int kTargets = 5;  // N, T, T2 or (u, v, s_math), P, (u, v)
  const gl::Program p(shaders::vertex_vert, shaders::gbuffer_frag, "gbuffer.frag");
  fb.draw_to(kTargets);
  glClearColor(0, 0, 0, 0);  // coverage is where a normal was written
  glDisable(GL_BLEND);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  p.use();
  p.set_matrix("uViewProj", view_proj);
  p.set("uFiber", fiber ? 1 : 0);
  mesh.draw();
  glFinish();
  GBuffer g{fb.read(0), fb.read(1), fb.read(2), fb.read(3), fb.read(4)};
  const int w = g.N.width, h = g.N.height;
  res->covered.assign(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      res->covered[static_cast<size_t>(y) * w + x] =
          (g.N.at(x, y, 0) != 0 || g.N.at(x, y, 1) != 0 || g.N.at(x, y, 2) != 0);
  return g;
}

void check_preview_request(const Material& m, const PreviewOptions& opt, bool fiber) {
  if (opt.width < 1 || opt.height < 1 || opt.width > 8192 || opt.height > 8192)
    throw Error("preview: --size must be between 1x1 and 8192x8192");
  if (fiber) {
    if (const auto* r = m.topology_as<SMapRef>(); r && opt.s_map.empty())
      throw Error("preview: the material uses a map of s (" + r->file + ") but none was loaded");
    if (const auto* r = m.topology_as<TopologyMapRef>(); r && opt.topology_map.empty())
      throw Error("preview: the material uses a topology map (" + r->file +
                  ") but none was loaded");
  }
  if (opt.environment) {
    const char* what = environment_unsupported(m);
    if (!what) what = opt.plain ? "--plain" : opt.per_vertex ? "--per-vertex" : nullptr;
    if (what)
      throw Error(
          std::string("preview: --env lights the line and the fiber model with one fiber, maps "
                      "of k_d, k_s and the fiber direction but not of n; not ") +
          what + " (light it with --light instead)");
    return;
  }
  if (opt.light_dirs.empty() && opt.point_lights.empty())
    throw Error("preview: at least one light is needed");
}

}  // namespace

void PreviewLight::at(const Vec3& P, Vec3* L, double* E) const {
  if (!point) {
    *L = dir;
    *E = irradiance;
    return;
  }
  const Vec3 d = pos - P;
  const double r = length(d);
  *L = d * (1.0 / r);
  *E = irradiance * d0 * d0 / (r * r);
}

std::vector<PreviewLight> preview_lights(const PreviewOptions& opt, const Vec3& center) {
  std::vector<PreviewLight> lights;
  auto directional = [](const Vec3& d, double e) {
    PreviewLight l;
    l.dir = normalize(d);
    l.irradiance = e;
    return l;
  };
  for (const Vec3& d : opt.light_dirs) lights.push_back(directional(d, 1.0));
  if (opt.fill > 0) lights.push_back(directional(opt.view_dir, opt.fill));
  for (const Vec3& p : opt.point_lights) {
    PreviewLight l;
    l.point = true;
    l.pos = p;
    l.d0 = length(p - center);
    l.dir = normalize(p - center);
    lights.push_back(l);
  }
  return lights;
}

void prefilter_for_frames(const Material& m, PreviewOptions* p, PreviewPrefiltered* keep) {
  if (!p->environment || !p->baked) return;
  if (m.isotropic_active() && !p->prefiltered_isotropic) {
    keep->isotropic = prefilter_isotropic_environment(*p->environment, m.iso_n);
    p->prefiltered_isotropic = &keep->isotropic;
  }
  if (m.fiber()) {
    if (!p->prefiltered_fiber && p->baked_fiber) {
      keep->fiber = prefilter_fiber_environment(*p->environment, m, *p->baked, *p->baked_fiber);
      p->prefiltered_fiber = &keep->fiber;
    }
  } else if (m.maps.any()) {
    if (!p->prefiltered_parts) {
      keep->parts = prefilter_environment_parts(*p->environment, *p->baked, &m);
      p->prefiltered_parts = &keep->parts;
    }
  } else if (!p->prefiltered) {
    keep->tables = prefilter_environment(*p->environment, *p->baked);
    p->prefiltered = &keep->tables;
  }
}

void bake_for_frames(const Material& m, PreviewOptions* p, PreviewBakes* keep) {
  if (!p->baked) {
    const bool paper = p->per_vertex && !p->plain && !m.fiber();  // as render_preview
    keep->tables = bake_line(
        m, p->table_size, p->table_index == 1 && !paper ? BakeIndex::kAngle : BakeIndex::kCosine);
    p->baked = &keep->tables;
  }
  if (m.fiber() && !p->baked_fiber) {
    keep->fiber = bake_fiber(m, *p->baked, 64, 9, 16, 1, p->progress);
    p->baked_fiber = &keep->fiber;
  }
  if (!m.maps.n || p->plain) return;
  if (!p->baked_stack) {
    keep->stack = bake_material_stack(m, p->baked->size, p->baked->index);
    p->baked_stack = &keep->stack;
  }
  if (m.fiber() && !p->baked_fiber_stack) {
    keep->fiber_stack =
        bake_fiber_stack(m, *p->baked_fiber, *p->baked, *p->baked_stack, 0.2, 28, 1, p->progress);
    p->baked_fiber_stack = &keep->fiber_stack;
  }
}

PreviewResult render_preview(const Material& m, const PreviewOptions& opt) {
  const bool fiber = m.fiber() && !opt.plain;
  check_preview_request(m, opt, fiber);
  const bool is_obj = lower_ext(opt.shape) == ".obj";
  const TriMesh mesh = is_obj ? load_obj(opt.shape, opt.fiber_field.empty())
                              : make_shape(opt.shape, opt.shape_options);
  PreviewResult res;
  res.triangles = mesh.tri.size();
  double radius = 0;
  const std::vector<float> vbuf = vertex_attributes(m, opt, mesh, &radius);

  std::unique_ptr<gl::Context> context;
  if (!opt.use_current_context) context = std::make_unique<gl::Context>();
  res.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const int w = opt.width, h = opt.height;
  std::vector<uint32_t> indices;
  indices.reserve(mesh.tri.size() * 3);
  for (const auto& t : mesh.tri) indices.insert(indices.end(), t.begin(), t.end());
  const gl::MeshBuffers buffers(vbuf, kAttributeSizes, indices);
  // Five float colour targets (the geometry pass uses all of them) and depth.
  const gl::Framebuffer fb(w, h, 5);
  PreviewCamera cam;
  cam.V = normalize(opt.view_dir);
  cam.perspective = opt.perspective;
  if (opt.perspective)
    cam.eye = perspective_view_proj(cam.V, mesh.center, radius, double(w) / h, cam.view_proj);
  else
    ortho_view_proj(cam.V, mesh.center, radius, double(w) / h, cam.view_proj);
  const std::vector<PreviewLight> lights = preview_lights(opt, mesh.center);

  const bool paper = opt.per_vertex && !opt.plain && !m.fiber();
  if (paper && m.maps.any())
    throw Error(
        "preview: --per-vertex (the paper's construction) cannot follow a material's maps, which "
        "vary per fragment: leave out --per-vertex");
  if (paper && (opt.perspective || !opt.point_lights.empty()))
    throw Error(
        "preview: --per-vertex (the paper's construction) needs directional lights and a "
        "distant viewer: leave out --perspective and --point-light");
  Lookups lk;
  make_lookups(m, opt, fiber, paper, &lk);
  Passes ps;
  ps.fiber = fiber;
  if (paper)
    ps.aniso = std::make_unique<gl::Program>(shaders::vertex_paper_vert, shaders::aniso_paper_frag,
                                             "aniso_paper.frag");
  else
    ps.aniso = std::make_unique<gl::Program>(
        shaders::vertex_vert,
        with_maps(opt.plain ? shaders::plain_frag
                            : (fiber ? shaders::fiber_frag : shaders::aniso_frag))
            .c_str(),
        opt.plain ? "plain.frag" : (fiber ? "fiber.frag" : "aniso.frag"));
  ps.iso = std::make_unique<gl::Program>(shaders::vertex_vert, shaders::iso_frag, "iso.frag");

  EnvironmentLookup env;
  std::unique_ptr<gl::Program> env_pass;
  if (opt.environment) {
    // What the caller did not prefilter once for many frames, prefiltered here for this one.
    PreviewOptions with = opt;
    with.baked = &lk.tables;
    with.baked_fiber = &lk.fb;
    PreviewPrefiltered own;
    prefilter_for_frames(m, &with, &own);
    if (const IsotropicEnvironment* it = with.prefiltered_isotropic) {
      env.iso_irr.volume_rgb(it->irradiance, it->w, it->h, 1);
      env.iso_gloss.volume_rgb(it->glossy, it->w, it->h, 1);
      env.iso = true;
      std::copy(std::begin(it->scale), std::end(it->scale), env.iso_scale);
      res.env_prefilter_seconds += it->seconds;
    }
    if (fiber) {
      const FiberEnvironmentTables& ft = *with.prefiltered_fiber;
      fiber_environment_volumes(ft, &env);
      res.env_prefilter_seconds += ft.seconds;
      res.env_sizes.w = ft.w, res.env_sizes.h = ft.h, res.env_sizes.nb = ft.nb;
      res.env_sizes.env_w = ft.env_w, res.env_sizes.env_h = ft.env_h;
      env_pass = std::make_unique<gl::Program>(
          shaders::vertex_vert, with_maps(shaders::env_fiber_frag).c_str(), "env_fiber.frag");
    } else {
      env.parts = m.maps.any();  // D and S apart: the maps' k_d and k_s apply per fragment
      const EnvironmentParts* parts = with.prefiltered_parts;
      const EnvironmentTables& et = env.parts ? parts->diffuse : *with.prefiltered;
      // A material with maps: D's and S's terms packed into one volume each (with a map of n,
      // S's levels of n one above the other).
      if (env.parts) {
        env.n_levels = std::max<int>(1, static_cast<int>(parts->specular_n.size()));
        env.logn0 = parts->logn0, env.log_step = parts->log_step;
        env.part_d.volume_rgb(environment_parts_d_volume(*parts), et.w, et.h, 7 * et.nb);
        env.part_s.volume_rgb(environment_parts_s_volume(*parts), et.w, et.h * env.n_levels,
                              7 * et.nb);
      } else {
        for (int t = 0; t < 7; ++t) env.terms[t].volume_rgb(et.terms[t], et.w, et.h, et.nb);
      }
      env.levels = et.nb;
      env.rows = et.h;
      res.env_prefilter_seconds +=
          env.parts ? parts->diffuse.seconds + parts->specular.seconds : et.seconds;
      res.env_sizes.w = et.w, res.env_sizes.h = et.h, res.env_sizes.nb = et.nb;
      res.env_sizes.env_w = et.env_w, res.env_sizes.env_h = et.env_h;
      env_pass = std::make_unique<gl::Program>(shaders::vertex_vert,
                                               with_maps(shaders::env_frag).c_str(), "env.frag");
    }
  }

  fb.draw_to(1);
  glEnable(GL_DEPTH_TEST);
  const auto t0 = std::chrono::steady_clock::now();
  for (int frame = 0; frame < std::max(1, opt.repeat); ++frame)
    res.passes = env_pass ? draw_environment(m, opt, *env_pass, env, lk, buffers, cam)
                          : draw_frame(m, opt, ps, lk, buffers, cam, lights);
  res.frames = std::max(1, opt.repeat);
  res.seconds_per_frame =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
      std::max(1, opt.repeat);
  res.rgb = fb.read(0);

  // Coverage and, when asked, the direct evaluation at the same fragments.
  const GBuffer g = geometry_pass(fb, buffers, cam.view_proj, fiber, &res);
  res.fiber_stack_levels = lk.fstack.levels;
  res.fiber_stack_seconds = lk.fstack.seconds;
  res.fiber_stack_error = lk.fstack.max_abs_error;
  res.n_min = std::exp(lk.fstack.logn0), res.n_max = std::exp(lk.fstack.logn1);
  if (opt.reference && fiber && !opt.environment)
    fiber_reference(m, opt, cam, lights, lk.tables, lk.fb,
                    lk.fstack.levels > 0 ? &lk.stack : nullptr, &lk.fstack, g, &res);
  if (opt.reference && opt.environment)
    environment_reference(m, opt, cam, *opt.environment, kEnvironmentReferenceW,
                          kEnvironmentReferenceW / 2, g, &res);
  else if (opt.reference && !opt.plain && !fiber)
    line_reference(m, opt, cam, lights, lk.tables, lk.maps ? &lk.stack : nullptr, g, &res);
  return res;
}

}  // namespace aniso
