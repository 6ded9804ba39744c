#include "geometry/mesh.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>

#include "core/error.h"

namespace aniso {

Vec3 any_perpendicular(const Vec3& N) {
  const Vec3 a = std::abs(N.x) < 0.9 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  return normalize(a - N * dot(a, N));
}

FiberField parse_fiber_field(const std::string& field) {
  if (field == "radial") return FiberField::kRadial;
  if (field == "circular") return FiberField::kCircular;
  if (field == "meridian") return FiberField::kMeridian;
  return FiberField::kMesh;
}

namespace {

// A (nu+1) x (nv+1) vertex grid over a parametric surface f(u, v) -> (P, N, dP/du).
template <class F>
TriMesh grid(int nu, int nv, F f) {
  TriMesh m;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const double u = static_cast<double>(i) / nu, v = static_cast<double>(j) / nv;
      Vec3 P, N, U;
      f(u, v, &P, &N, &U);
      m.P.push_back(P);
      m.N.push_back(N);
      m.U.push_back(U);
      m.uv.push_back({static_cast<float>(u), static_cast<float>(v)});
    }
  auto id = [&](int i, int j) { return static_cast<uint32_t>(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      m.tri.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.tri.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

}  // namespace

const std::vector<std::string>& shape_names() {
  static const std::vector<std::string> names = {"flat", "disc", "sphere", "cylinder", "torus"};
  return names;
}

TriMesh make_shape(const std::string& name, const ShapeOptions& opt) {
  const int n = std::max(8, opt.resolution);
  const double tau = 2 * M_PI;
  TriMesh m;
  if (name == "flat") {
    m = grid(1, 1, [](double u, double v, Vec3* P, Vec3* N, Vec3* U) {
      *P = {2 * u - 1, 1 - 2 * v, 0};
      *N = {0, 0, 1};
      *U = {1, 0, 0};
    });
    m.can_self_shadow = false;
  } else if (name == "disc") {
    // u around, v outward; U defaults to +x like a flat sample (fiber fields replace it).
    m = grid(n, n / 4, [&](double u, double v, Vec3* P, Vec3* N, Vec3* U) {
      const double a = -tau * u, r = v;
      *P = {r * std::cos(a), r * std::sin(a), 0};
      *N = {0, 0, 1};
      *U = {1, 0, 0};
    });
    for (auto& t : m.uv)
      t = {0.5f + 0.5f * t[1] * std::cos(-float(tau) * t[0]),
           0.5f - 0.5f * t[1] * std::sin(-float(tau) * t[0])};
    m.can_self_shadow = false;
  } else if (name == "sphere") {
    m = grid(n, n / 2, [&](double u, double v, Vec3* P, Vec3* N, Vec3* U) {
      const double phi = tau * u, th = M_PI * v;  // v = 0 at the north pole
      *P = {std::sin(th) * std::cos(phi), std::sin(th) * std::sin(phi), std::cos(th)};
      *N = *P;
      *U = {-std::sin(phi), std::cos(phi), 0};
    });
    m.can_self_shadow = false;
  } else if (name == "cylinder") {
    m = grid(n, n / 4, [&](double u, double v, Vec3* P, Vec3* N, Vec3* U) {
      const double phi = tau * u;
      *P = {std::cos(phi), std::sin(phi), 1 - 2 * v};
      *N = {std::cos(phi), std::sin(phi), 0};
      *U = {-std::sin(phi), std::cos(phi), 0};
    });
    m.can_self_shadow = true;  // open tube: its inside can be shadowed by its wall
  } else if (name == "torus") {
    const double R = opt.torus_R, r = opt.torus_r;
    if (!(R > r && r > 0)) throw Error("torus: needs major radius > minor radius > 0");
    m = grid(n, n / 2, [&](double u, double v, Vec3* P, Vec3* N, Vec3* U) {
      const double phi = tau * u, th = tau * v;  // th = 0 on the outside (docs/models.md §4)
      const Vec3 out{std::cos(phi), std::sin(phi), 0};
      *N = out * std::cos(th) + Vec3(0, 0, std::sin(th));
      *P = out * R + *N * r;
      *U = {-std::sin(phi), std::cos(phi), 0};
    });
    m.can_self_shadow = true;
    m.torus_R = R;
    m.torus_r = r;
  } else {
    std::string list;
    for (const auto& s : shape_names()) list += (list.empty() ? "" : ", ") + s;
    throw Error("unknown shape '" + name + "' (" + list + ", or an .obj file)");
  }
  return m;
}

namespace {

// What an OBJ file holds, as read: positions, texture coordinates (v flipped to glTF's
// downward), normals and triangles of 1-based corner indices (0 = absent).
struct ObjCorner {
  long v = 0, t = 0, n = 0;
};
struct ObjData {
  std::vector<Vec3> v, vn;
  std::vector<std::array<float, 2>> vt;
  std::vector<std::array<ObjCorner, 3>> faces;
};

// One face corner "v", "v/t", "v//n" or "v/t/n"; negative indices count back from the end.
ObjCorner parse_corner(const std::string& tok, const ObjData& d,
                       const std::function<void(const std::string&)>& fail) {
  ObjCorner c;
  long* fields[3] = {&c.v, &c.t, &c.n};
  size_t start = 0;
  for (int k = 0; k < 3 && start <= tok.size(); ++k) {
    const size_t slash = tok.find('/', start);
    const std::string part =
        tok.substr(start, slash == std::string::npos ? std::string::npos : slash - start);
    if (!part.empty()) {
      try {
        *fields[k] = std::stol(part);
      } catch (...) {
        fail("bad face index '" + tok + "'");
      }
    }
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  auto fix = [&](long& i, size_t count) {
    if (i < 0) i = static_cast<long>(count) + i + 1;
    if (i < 0 || i > static_cast<long>(count)) fail("face index out of range in '" + tok + "'");
  };
  fix(c.v, d.v.size());
  fix(c.t, d.vt.size());
  fix(c.n, d.vn.size());
  if (c.v == 0) fail("face corner without a vertex");
  return c;
}

ObjData parse_obj(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(path + ": file not found");
  ObjData d;
  std::string line;
  int lineno = 0;
  const std::function<void(const std::string&)> fail = [&](const std::string& msg) {
    throw Error(path + ":" + std::to_string(lineno) + ": " + msg);
  };
  while (std::getline(f, line)) {
    ++lineno;
    std::istringstream ss(line);
    std::string tag;
    ss >> tag;
    if (tag == "v") {
      Vec3 p;
      if (!(ss >> p.x >> p.y >> p.z)) fail("bad vertex");
      d.v.push_back(p);
    } else if (tag == "vt") {
      float a, b;
      if (!(ss >> a >> b)) fail("bad texture coordinate");
      d.vt.push_back({a, 1.0f - b});  // OBJ counts v upward; glTF downward
    } else if (tag == "vn") {
      Vec3 p;
      if (!(ss >> p.x >> p.y >> p.z)) fail("bad normal");
      d.vn.push_back(normalize(p));
    } else if (tag == "f") {
      std::vector<ObjCorner> poly;
      std::string tok;
      while (ss >> tok) poly.push_back(parse_corner(tok, d, fail));
      if (poly.size() < 3) fail("face with fewer than 3 corners");
      for (size_t k = 1; k + 1 < poly.size(); ++k)
        d.faces.push_back({poly[0], poly[k], poly[k + 1]});
    }
  }
  if (d.faces.empty()) throw Error(path + ": no faces");
  return d;
}

}  // namespace

TriMesh load_obj(const std::string& path, bool need_uv) {
  const ObjData d = parse_obj(path);
  TriMesh m;
  // One output vertex per corner (simple and exact for seams); U accumulated per triangle.
  const std::string uv_hint =
      ": the reference tangent U is dP/du, so every face needs texture coordinates (vt) that "
      "span an area; add them, or give a fiber_field (radial, circular, meridian)";
  for (const auto& fc : d.faces) {
    if (need_uv && (!fc[0].t || !fc[1].t || !fc[2].t))
      throw Error(path + ": a face has no texture coordinates" + uv_hint);
    const uint32_t base = static_cast<uint32_t>(m.P.size());
    Vec3 p[3];
    std::array<float, 2> t[3];
    for (int k = 0; k < 3; ++k) {
      p[k] = d.v[fc[k].v - 1];
      t[k] = fc[k].t ? d.vt[fc[k].t - 1] : std::array<float, 2>{0.f, 0.f};
    }
    const Vec3 fn = normalize(cross(p[1] - p[0], p[2] - p[0]));
    // dP/du from the UV parallelogram; OBJ-space u is unchanged by the v flip.
    const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const double du1 = t[1][0] - t[0][0], du2 = t[2][0] - t[0][0];
    const double dv1 = t[1][1] - t[0][1], dv2 = t[2][1] - t[0][1];
    const double det = du1 * dv2 - du2 * dv1;
    if (need_uv && !(std::abs(det) > 1e-20))
      throw Error(path + ": a face's texture coordinates are degenerate (zero area)" + uv_hint);
    Vec3 dpdu = std::abs(det) > 1e-20 ? (e1 * dv2 - e2 * dv1) / det : any_perpendicular(fn);
    for (int k = 0; k < 3; ++k) {
      m.P.push_back(p[k]);
      m.N.push_back(fc[k].n ? d.vn[fc[k].n - 1] : fn);
      m.U.push_back(dpdu);
      m.uv.push_back(t[k]);
    }
    m.tri.push_back({base, base + 1, base + 2});
  }
  Vec3 lo = m.P[0], hi = m.P[0];
  for (const auto& q : m.P) {
    lo = {std::min(lo.x, q.x), std::min(lo.y, q.y), std::min(lo.z, q.z)};
    hi = {std::max(hi.x, q.x), std::max(hi.y, q.y), std::max(hi.z, q.z)};
  }
  m.center = (lo + hi) * 0.5;
  m.can_self_shadow = true;
  return m;
}

}  // namespace aniso
