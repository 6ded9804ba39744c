// import_report.json (photo/import/import.h): calibration, every photo's result and why one was
// left out.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "io/files/json_util.h"
#include "photo/import/import.h"

namespace aniso {

std::string intensity_note(const Shoot& s, const ImportResult& r, bool found) {
  if (!found) return "as written in the shoot (import --lamps-as-written)";
  char buf[300];
  if (r.card.found) {
    std::snprintf(buf, sizeof buf,
                  "absolute: from the board's paper, its reflectance %.3f %.3f %.3f (+- %.3f) from "
                  "the grey card of reflectance %.3f (reference) in %zu photos",
                  r.card.paper[0], r.card.paper[1], r.card.paper[2], r.card.sigma[1],
                  s.reference.reflectance[1], r.card.photos);
    return buf;
  }
  if (s.paper_given())
    return "absolute: from the board's paper, of reflectance board.paper_reflectance";
  std::snprintf(
      buf, sizeof buf,
      "relative: from the board's paper taken as reflecting %.2f; k_d and k_s are "
      "relative to it (lay a grey card on the board and give it as the shoot's reference, "
      "or give board.paper_reflectance, to make them absolute)",
      kAssumedPaperReflectance);
  return buf;
}

nlohmann::json import_report_json(const Shoot& s, const ImportResult& r, const ImportOptions& o) {
  using nlohmann::json;
  json photos = json::array();
  for (size_t i = 0; i < r.photos.size(); ++i) {
    const ImportedPhoto& p = r.photos[i];
    json jp = {{"photo", i},
               {"files", p.files},
               {"markers", p.markers},
               {"corners", p.corners},
               {"corners_dropped_at_sample", p.corners_dropped},
               {"saturated_pixels", p.saturated_pixels},
               {"decoded_twice", p.decoded_twice},
               {"accepted", p.accepted}};
    if (!p.raw.empty()) {
      json raw = json::array();
      for (const auto& ri : p.raw)
        raw.push_back({{"decoded_by",
                        "LibRaw's unpacking; developed linearly (no transfer curve, no "
                        "auto-brightness), camera white balance, sRGB primaries, by " +
                            ri.developed_by},
                       {"camera", ri.camera},
                       {"white_balance_rgbg", ri.white_balance}});
      jp["raw"] = raw;
    }
    if (p.rms_px >= 0) {
      jp["rms_px"] = p.rms_px;
      jp["tilt_deg"] = p.tilt_deg;
      jp["camera_position_m"] = jsonu::to_json(p.world_from_camera.translation());
    }
    if (!p.lamps.empty()) {
      json lamps = json::array();
      for (const auto& l : p.lamps) {
        json jl = {{"written",
                    {{"position_m", jsonu::to_json(l.written)},
                     {"position_sigma_m", l.prior_sigma_m},
                     {"intensity", jsonu::to_json(l.written_intensity)}}}};
        if (l.solved) {
          jl["found"] = {{"position_m", jsonu::to_json(l.found)},
                         {"position_sigma_m", l.sigma_m},
                         {"intensity", jsonu::to_json(l.found_intensity)},
                         {"moved_sigmas", l.moved_sigmas},
                         {"paper_points", l.points},
                         {"paper_relative_rms", l.paper_rms}};
          if (l.card_points > 0) {
            jl["found"]["card_points"] = l.card_points;
            jl["found"]["card_relative_rms"] = l.card_rms;
            jl["found"]["paper_over_card"] = {l.paper_amplitude[0] / l.card_amplitude[0],
                                              l.paper_amplitude[1] / l.card_amplitude[1],
                                              l.paper_amplitude[2] / l.card_amplitude[2]};
          }
        } else {
          jl["kept_as_written_because"] = l.why;
        }
        lamps.push_back(jl);
      }
      jp["lamps"] = lamps;
    }
    if (p.accepted) {
      jp["view"] = p.view;
      jp["sample_pixels"] = p.sample_pixels;
    } else {
      jp["left_out_because"] = p.reason;
    }
    photos.push_back(jp);
  }
  json cal = camera_json(r.camera);
  cal["source"] = r.calibrated
                      ? "calibrated from the photos (OpenCV calibrateCameraCharuco, k3 fixed at 0)"
                      : "given in the shoot";
  if (r.calibrated) {
    cal["rms_px"] = r.calibration_rms_px;
    cal["sigma_fx_fy_cx_cy_px"] = r.sigma;
    cal["calibrated_on_photos"] = r.calibrated_on;
    cal["held"] = r.held;
  }
  return {{"format", "aniso-import-report"},
          {"version", 1},
          {"shoot", s.file},
          {"camera", cal},
          {"merge",
           "own: decoded by color, clipped codes dropped, near-black codes only as a last "
           "resort, weighted by exposure (photo/shoot/merge.h says why not cv::MergeDebevec)"},
          {"options",
           {{"max_rms_px", o.max_rms_px},
            {"sample_margin_m", o.sample_margin_m},
            {"min_corners", o.min_corners},
            {"memory_mb", o.memory_mb},
            {"calibrate_on", o.calibrate_on}}},
          {"memory",
           {{"photos_merged_at_once", r.merge_threads},
            {"estimate_mb", r.memory_estimate_mb},
            {"crop_budget_mb", r.crop_budget_mb}}},
          {"photos", photos},
          {"views", r.views},
          {"intensities", r.intensities},
          {"warnings", r.warnings},
          {"vignetting",
           r.vignetting.found
               ? json{{"model",
                       "V(r) = 1 + a1 r^2 + a2 r^4, r the distance from the principal point "
                       "(centre_px) over the image's half diagonal; where applied (V at the "
                       "paper's largest r more than 3 sigma "
                       "from 1) the lamps are found through it and the views' images divided by "
                       "it"},
                      {"centre_px", {r.vignetting.cx, r.vignetting.cy}},
                      {"a1", r.vignetting.a1},
                      {"a2", r.vignetting.a2},
                      {"sigma_a1", r.vignetting.sigma_a1},
                      {"sigma_a2", r.vignetting.sigma_a2},
                      {"corner", r.vignetting.at(0, 0)},
                      {"applied", r.vignetting.applied},
                      {"sigma_at_r_max", r.vignetting.sigma_edge},
                      {"r_max_seen", r.vignetting.r_max},
                      {"photos", r.vignetting.photos},
                      {"points", r.vignetting.points}}
               : json(nullptr)},
          {"reference", s.reference_given()
                            ? json{{"reflectance", jsonu::to_json(s.reference.reflectance)},
                                   {"read", r.card.found},
                                   {"photos", r.card.photos},
                                   {"points", r.card.points},
                                   {"paper_reflectance_found", jsonu::to_json(r.card.paper)},
                                   {"paper_reflectance_sigma", jsonu::to_json(r.card.sigma)}}
                            : json(nullptr)},
          {"caveats",
           {"lamps are found from the board's paper where they are point lamps of "
            "inverse-square falloff (several in a photo together); other lights are taken as "
            "written",
            "the paper is taken as Lambertian; the lens's vignetting as 1 + a1 r^2 + a2 r^4 "
            "about the principal point",
            "the sample is a plane at z = -height_m; a warped or thick sample is not modelled"}},
          {"seconds",
           {{"detect", r.seconds_detect},
            {"calibrate", r.seconds_calibrate},
            {"write", r.seconds_write},
            {"total", r.seconds}}}};
}

}  // namespace aniso
