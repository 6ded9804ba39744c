#include "photo/shoot/shoot.h"

#include <cmath>
#include <filesystem>

#include "io/files/files.h"
#include "io/files/json_util.h"

namespace aniso {

using jsonu::Ctx;
using jsonu::json;

bool inside_polygon(const std::vector<std::array<double, 2>>& poly, double x, double y) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a[1] > y) != (b[1] > y) && x < (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]) + a[0]) in = !in;
  }
  return in;
}

double distance_to_outline(const std::vector<std::array<double, 2>>& poly, double x, double y) {
  double best = INFINITY;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const double ax = poly[j][0], ay = poly[j][1], bx = poly[i][0], by = poly[i][1];
    const double ex = bx - ax, ey = by - ay, len2 = ex * ex + ey * ey;
    const double t = len2 > 0 ? std::clamp(((x - ax) * ex + (y - ay) * ey) / len2, 0.0, 1.0) : 0;
    best = std::min(best, std::hypot(x - ax - t * ex, y - ay - t * ey));
  }
  return best;
}

namespace {

BoardSpec parse_board(const json& j, const Ctx& c, RGB* paper) {
  jsonu::check_keys(j,
                    {"type", "dictionary", "squares", "square_m", "marker_m", "printed_from",
                     "paper_reflectance"},
                    c);
  if (j.contains("paper_reflectance")) {
    *paper = jsonu::rgb(j["paper_reflectance"], c.at("paper_reflectance"));
    for (double v : *paper)
      if (!(v > 0.05 && v <= 1))
        c.at("paper_reflectance")
            .fail(
                "must be in (0.05, 1]: the printed paper's diffuse reflectance (office paper: "
                "about 0.85)");
  }
  const std::string type = jsonu::str(jsonu::need(j, "type", c), c.at("type"));
  if (type != "charuco") c.at("type").fail("unknown board type '" + type + "' (charuco)");
  BoardSpec b;
  b.dictionary = jsonu::str(jsonu::need(j, "dictionary", c), c.at("dictionary"));
  const json& sq = jsonu::need(j, "squares", c);
  if (!sq.is_array() || sq.size() != 2) c.at("squares").fail("expected [squares_x, squares_y]");
  b.squares_x = static_cast<int>(jsonu::num(sq[0], c.at("squares").idx(0)));
  b.squares_y = static_cast<int>(jsonu::num(sq[1], c.at("squares").idx(1)));
  b.square_m = jsonu::num(jsonu::need(j, "square_m", c), c.at("square_m"));
  b.marker_m = jsonu::num(jsonu::need(j, "marker_m", c), c.at("marker_m"));
  try {
    check_board(b);
  } catch (const Error& e) {
    c.fail(e.what());
  }
  return b;
}

// An outline on the board: at least 3 [x, y] points in metres, inside the board, enclosing some
// area.
std::vector<std::array<double, 2>> parse_polygon(const json& poly, const Ctx& pc,
                                                 const BoardSpec& b) {
  if (!poly.is_array() || poly.size() < 3) pc.fail("expected at least 3 [x, y] points (metres)");
  const double W = b.squares_x * b.square_m;
  const double H = b.squares_y * b.square_m;
  std::vector<std::array<double, 2>> out;
  for (size_t i = 0; i < poly.size(); ++i) {
    if (!poly[i].is_array() || poly[i].size() != 2) pc.idx(i).fail("expected [x, y] in metres");
    const double x = jsonu::num(poly[i][0], pc.idx(i).idx(0));
    const double y = jsonu::num(poly[i][1], pc.idx(i).idx(1));
    if (x < 0 || y < 0 || x > W || y > H)
      pc.idx(i).fail("(" + std::to_string(x) + ", " + std::to_string(y) +
                     ") m is off the board (0..." + std::to_string(W) + ", 0..." +
                     std::to_string(H) +
                     " m); board coordinates are metres from its top-left "
                     "corner, x right, y down");
    out.push_back({x, y});
  }
  double area = 0;
  for (size_t i = 0, k = out.size() - 1; i < out.size(); k = i++)
    area += out[k][0] * out[i][1] - out[i][0] * out[k][1];
  if (std::abs(area) / 2 < 1e-6) pc.fail("encloses no area (less than 1 mm^2)");
  return out;
}

void parse_sample(const json& j, const Ctx& c, Shoot* s) {
  jsonu::check_keys(j, {"polygon_m", "height_m", "tangent"}, c);
  s->polygon = parse_polygon(jsonu::need(j, "polygon_m", c), c.at("polygon_m"), s->board);
  s->height_m = jsonu::num_or(j, "height_m", 0.0, c);
  if (s->height_m < 0 || s->height_m > 0.5) c.at("height_m").fail("must be in [0, 0.5] m");
  if (j.contains("tangent")) {
    const json& t = j["tangent"];
    if (!t.is_array() || t.size() != 2) c.at("tangent").fail("expected [x, y] on the board");
    const double tx = jsonu::num(t[0], c.at("tangent").idx(0));
    const double ty = jsonu::num(t[1], c.at("tangent").idx(1));
    const double len = std::hypot(tx, ty);
    if (!(len > 1e-9)) c.at("tangent").fail("zero vector");
    s->tangent = {tx / len, ty / len};
  }
}

// A light must be on the printed side (z < 0) and reach the sample from above its surface.
void check_light(const Light& l, const Ctx& c, double height_m) {
  if (l.type == Light::Type::kDirectional) {
    if (!(l.direction.z < 0))
      c.at("direction").fail("points to z >= 0: behind the board (the printed side is -z)");
  } else if (!(l.position.z < -height_m)) {
    c.at("position")
        .fail("z = " + std::to_string(l.position.z) +
              " is on the wrong side of the board: the printed face, camera and "
              "lamps are at z < 0 (z points into the board)");
  } else if (constexpr double kFarM = 5; length(l.position) > kFarM) {
    // A desk lamp lights a sample from within a metre or two: tens of metres are centimetres.
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "the lamp is %.1f m from the board's corner: positions are in metres (were they "
                  "written in centimetres or millimetres?)",
                  length(l.position));
    c.at("position").fail(buf);
  }
}

// A grey card on the board (docs/formats.md "Additions"): its outline and reflectance, apart from
// the sample.
void parse_reference(const json& j, const Ctx& c, Shoot* s) {
  jsonu::check_keys(j, {"polygon_m", "reflectance"}, c);
  auto& card = s->reference;
  card.polygon = parse_polygon(jsonu::need(j, "polygon_m", c), c.at("polygon_m"), s->board);
  card.reflectance = jsonu::rgb(jsonu::need(j, "reflectance", c), c.at("reflectance"));
  for (double v : card.reflectance)
    if (!(v >= 0.02 && v <= 1))
      c.at("reflectance")
          .fail(
              "must be in [0.02, 1]: the card's diffuse reflectance (a photographer's grey "
              "card: 0.18)");
  for (const auto& p : card.polygon)
    if (inside_polygon(s->polygon, p[0], p[1]))
      c.at("polygon_m").fail("lies on the sample (sample.polygon_m): the card goes beside it");
  for (const auto& p : s->polygon)
    if (inside_polygon(card.polygon, p[0], p[1]))
      c.at("polygon_m").fail("covers the sample (sample.polygon_m): the card goes beside it");
}

ShootPhoto parse_photo(const json& j, const Ctx& c, const Shoot& s) {
  jsonu::check_keys(j, {"images", "lights"}, c);
  ShootPhoto p;
  const json& imgs = jsonu::need(j, "images", c);
  if (!imgs.is_array() || imgs.empty()) c.at("images").fail("expected a non-empty array");
  for (size_t i = 0; i < imgs.size(); ++i) {
    const Ctx ic = c.at("images").idx(i);
    jsonu::check_keys(imgs[i], {"file", "exposure"}, ic);
    ShootImage im;
    im.file = jsonu::str(jsonu::need(imgs[i], "file", ic), ic.at("file"));
    im.exposure = jsonu::num_or(imgs[i], "exposure", 1.0, ic);
    if (!(im.exposure > 0)) ic.at("exposure").fail("must be positive");
    const std::string path = join_path(s.dir, im.file);
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) ic.at("file").fail(path + ": photo not found");
    p.images.push_back(im);
  }
  const json& lights = jsonu::need(j, "lights", c);
  if (!lights.is_array() || lights.empty()) c.at("lights").fail("a photo needs at least one light");
  for (size_t k = 0; k < lights.size(); ++k) {
    const Ctx lc = c.at("lights").idx(k);
    json l = lights[k];
    double sigma = kDefaultLampSigmaM;
    if (l.is_object() && l.contains("position_sigma_m")) {
      sigma = jsonu::num(l["position_sigma_m"], lc.at("position_sigma_m"));
      if (!(sigma > 0 && sigma <= 1))
        lc.at("position_sigma_m")
            .fail(
                "must be in (0, 1] m: how well the lamp's position was measured (a tape: 0.01 "
                "to 0.03)");
      l.erase("position_sigma_m");
    }
    p.lights.push_back(parse_light(l, lc));
    p.position_sigma_m.push_back(sigma);
    check_light(p.lights.back(), lc, s.height_m);
  }
  return p;
}

}  // namespace

Shoot read_shoot(const std::string& path) {
  Shoot s;
  s.file = path;
  s.dir = parent_dir(path);
  const json j = jsonu::parse_file(read_text_file(path), path);
  const Ctx root{path, ""};
  if (!j.is_object()) root.fail("expected a JSON object");
  jsonu::check_keys(
      j, {"format", "version", "board", "sample", "reference", "camera", "color", "photos"}, root);
  const std::string format = jsonu::str(jsonu::need(j, "format", root), root.at("format"));
  if (format != "aniso-shoot")
    root.at("format").fail("expected \"aniso-shoot\", got \"" + format + "\"");
  if (jsonu::num(jsonu::need(j, "version", root), root.at("version")) != 1)
    root.at("version").fail("unsupported version (this reader knows 1)");
  s.board = parse_board(jsonu::need(j, "board", root), root.at("board"), &s.paper_reflectance);
  parse_sample(jsonu::need(j, "sample", root), root.at("sample"), &s);
  if (j.contains("reference")) parse_reference(j["reference"], root.at("reference"), &s);
  const json& cam = jsonu::need(j, "camera", root);
  if (!cam.is_null()) {
    s.camera = parse_camera(cam, root.at("camera"));
    s.camera_given = true;
  }
  if (j.contains("color")) s.color = parse_color(j["color"], root.at("color"));
  const json& photos = jsonu::need(j, "photos", root);
  if (!photos.is_array() || photos.empty()) root.at("photos").fail("expected a non-empty array");
  for (size_t i = 0; i < photos.size(); ++i)
    s.photos.push_back(parse_photo(photos[i], root.at("photos").idx(i), s));
  return s;
}

void write_shoot(const Shoot& s, const std::string& path) {
  json poly = json::array();
  for (const auto& p : s.polygon) poly.push_back({p[0], p[1]});
  json photos = json::array();
  for (const auto& p : s.photos) {
    json imgs = json::array(), lights = json::array();
    for (const auto& im : p.images) imgs.push_back({{"file", im.file}, {"exposure", im.exposure}});
    for (size_t k = 0; k < p.lights.size(); ++k) {
      json l = light_json(p.lights[k]);
      if (k < p.position_sigma_m.size() && p.position_sigma_m[k] != kDefaultLampSigmaM)
        l["position_sigma_m"] = p.position_sigma_m[k];
      lights.push_back(l);
    }
    photos.push_back({{"images", imgs}, {"lights", lights}});
  }
  const json cam = s.camera_given ? camera_json(s.camera) : json(nullptr);
  const char* enc = s.color.encoding == ColorSpec::Encoding::kSrgb ? "srgb" : "linear";
  json j = {
      {"format", "aniso-shoot"},
      {"version", 1},
      {"board",
       {{"type", "charuco"},
        {"dictionary", s.board.dictionary},
        {"squares", {s.board.squares_x, s.board.squares_y}},
        {"square_m", s.board.square_m},
        {"marker_m", s.board.marker_m}}},
      {"sample",
       {{"polygon_m", poly}, {"height_m", s.height_m}, {"tangent", {s.tangent[0], s.tangent[1]}}}},
      {"camera", cam},
      {"color", {{"encoding", enc}}},
      {"photos", photos}};
  if (s.paper_given()) j["board"]["paper_reflectance"] = jsonu::to_json(s.paper_reflectance);
  if (s.reference_given()) {
    json card = json::array();
    for (const auto& p : s.reference.polygon) card.push_back({p[0], p[1]});
    j["reference"] = {{"polygon_m", card},
                      {"reflectance", jsonu::to_json(s.reference.reflectance)}};
  }
  write_text_file(path, j.dump(2) + "\n");
}

}  // namespace aniso
