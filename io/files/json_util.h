// Typed access to JSON values with messages that name the file and the key path
// (e.g. "capture.json: views[2].lights[0].intensity: expected a number or an RGB triple").
// Include only from .cpp files: it pulls in nlohmann/json.
#pragma once
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "core/text.h"
#include "core/vec.h"
#include "models/material.h"

namespace aniso::jsonu {

using nlohmann::json;

struct Ctx {
  std::string file, path;
  Ctx at(const std::string& key) const { return {file, path.empty() ? key : path + "." + key}; }
  Ctx idx(size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  [[noreturn]] void fail(const std::string& msg) const {
    throw Error(file + ": " + (path.empty() ? "" : path + ": ") + msg);
  }
};

inline const json& need(const json& j, const std::string& key, const Ctx& c) {
  if (!j.is_object()) c.fail("expected an object");
  auto it = j.find(key);
  if (it == j.end()) c.at(key).fail("missing required key");
  return *it;
}

inline double num(const json& v, const Ctx& c) {
  if (!v.is_number()) c.fail("expected a number, got " + v.dump());
  const double d = v.get<double>();
  if (!std::isfinite(d)) c.fail("not a finite number");
  return d;
}

inline double num_or(const json& j, const std::string& key, double def, const Ctx& c) {
  auto it = j.find(key);
  return it == j.end() ? def : num(*it, c.at(key));
}

inline std::string str(const json& v, const Ctx& c) {
  if (!v.is_string()) c.fail("expected a string, got " + v.dump());
  return v.get<std::string>();
}

inline std::string str_or(const json& j, const std::string& key, const std::string& def,
                          const Ctx& c) {
  auto it = j.find(key);
  return it == j.end() ? def : str(*it, c.at(key));
}

inline Vec3 vec3(const json& v, const Ctx& c) {
  if (!v.is_array() || v.size() != 3) c.fail("expected an array of 3 numbers");
  return {num(v[0], c.idx(0)), num(v[1], c.idx(1)), num(v[2], c.idx(2))};
}

// An RGB triple or one number (grey).
inline RGB rgb(const json& v, const Ctx& c) {
  if (v.is_number()) {
    const double d = num(v, c);
    return {d, d, d};
  }
  if (!v.is_array() || v.size() != 3) c.fail("expected a number or an RGB triple");
  return {num(v[0], c.idx(0)), num(v[1], c.idx(1)), num(v[2], c.idx(2))};
}

inline json to_json(const RGB& v) { return json::array({v[0], v[1], v[2]}); }
inline json to_json(const Vec3& v) { return json::array({v.x, v.y, v.z}); }

// Rejects keys this reader does not know (docs/formats.md: a reader rejects what it does not
// understand), with a "did you mean" where a known key is close.
inline void check_keys(const json& j, const std::vector<std::string>& known, const Ctx& c) {
  if (!j.is_object()) return;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
    c.at(it.key()).fail("unknown key" + did_you_mean(it.key(), known) +
                        "; known keys here: " + [&] {
                          std::string s;
                          for (const auto& k : known) s += (s.empty() ? "" : ", ") + k;
                          return s;
                        }());
  }
}

// Parses a whole file; malformed JSON, numbers out of range (1e400) and duplicate keys are
// errors naming the file.
inline json parse_file(const std::string& text, const std::string& file) {
  std::vector<std::vector<std::string>> keys;  // keys seen in each open object
  std::string duplicate;
  const json::parser_callback_t cb = [&](int, json::parse_event_t ev, json& parsed) {
    if (ev == json::parse_event_t::object_start) keys.emplace_back();
    if (ev == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    if (ev == json::parse_event_t::key && !keys.empty()) {
      const std::string k = parsed.get<std::string>();
      if (std::find(keys.back().begin(), keys.back().end(), k) != keys.back().end() &&
          duplicate.empty())
        duplicate = k;
      keys.back().push_back(k);
    }
    return true;
  };
  json j;
  try {
    j = json::parse(text, cb);
  } catch (const json::exception& e) {
    throw Error(file + ": malformed JSON: " + e.what());
  }
  if (!duplicate.empty())
    throw Error(file + ": key '" + duplicate + "' appears twice in one object");
  return j;
}

}  // namespace aniso::jsonu

namespace aniso {
struct Light;
struct ColorSpec;
struct Intrinsics;
// One light, a "color" block and a camera of docs/formats.md (defined in io/formats/capture.cpp).
Light parse_light(const jsonu::json& j, const jsonu::Ctx& c);
ColorSpec parse_color(const jsonu::json& j, const jsonu::Ctx& c);
Intrinsics parse_camera(const jsonu::json& j, const jsonu::Ctx& c);
jsonu::json light_json(const Light& l);
jsonu::json camera_json(const Intrinsics& k);
}  // namespace aniso
