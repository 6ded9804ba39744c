// aniso fit: a capture set or a sample table in, a material file out.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

#include "cli/command.h"
#include "cli/terminal_progress.h"
#include "core/error.h"
#include "fit/fit.h"
#include "io/files/files.h"
#include "io/files/json_util.h"
#include "io/formats/capture.h"
#include "io/formats/material_io.h"
#include "io/formats/rgl_bsdf.h"
#include "io/formats/table.h"
#include "io/images/image_io.h"
#include "render/report/report_page.h"

namespace aniso::cli {

namespace {

// "st", "nd", "rd" or "th" after k (every 2nd, 3rd, 16th pixel).
const char* ordinal_suffix(int k) {
  if (k % 100 >= 11 && k % 100 <= 13) return "th";
  return k % 10 == 1 ? "st" : k % 10 == 2 ? "nd" : k % 10 == 3 ? "rd" : "th";
}

std::string millions(double x) {  // x / 10^6 as %g prints it
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x / 1e6);
  return buf;
}

struct FitArgs {
  std::string in, out, truth, maps, tile, global, maps_solver = "lm", solver = "fused", report;
  std::string maps_lanes = "auto";
  std::string compression = "none";  // the maps' EXRs
  bool mpi = false, force = false;
  FitOptions fo = [] {
    FitOptions o;
    o.threads = default_fit_threads();  // every core this process may use
    o.progress = terminal_progress();
    return o;
  }();
};

void print_report(FILE* o, const FitResult& r) {
  const FitReport& p = r.report;
  std::fprintf(
      o,
      "fit: %zu observations (%zu pixels) from %zu views; skipped: %zu masked, %zu saturated, "
      "%zu non-finite, %zu unlit, %zu implausible\n",
      p.observations, p.pixels, p.views, p.masked_out, p.saturated, p.nonfinite, p.unlit,
      p.implausible);
  if (!p.start.empty()) std::fprintf(o, "fit: start %s\n", p.start.c_str());
  if (p.maps_bands > 1)
    std::fprintf(o,
                 "fit: --maps in %d bands of texel rows (records ~%.1f MB in all, --maps-memory "
                 "%g MB at once, at most %g MB of pixels the views share; the largest band held "
                 "%.2f MB, %.2f MB of it the pixels its views share)\n",
                 p.maps_bands, p.maps_record_bytes / 1e6, r.report.maps_memory_mb,
                 kMapsSharedBandBytes / 1e6, p.maps_band_peak_bytes / 1e6,
                 p.maps_band_shared_bytes / 1e6);
  if (p.maps_bands > 1 && p.maps_own_geometries > 0)
    std::fprintf(o,
                 "fit: note: %zu geometries (a camera per view): every band reads each again "
                 "(the first band whole, the later ones their own rows of it), %d times in all; a "
                 "larger --maps-memory, where memory allows, reads them fewer times\n",
                 p.maps_own_geometries, p.maps_bands);
  if (p.global_subsample > 0) {
    char records[160] = "";
    if (p.maps_record_bytes > p.maps_memory_mb * 1e6)
      std::snprintf(records, sizeof records,
                    "the records of every pixel (~%.0f MB) pass --maps-memory (%g MB): ",
                    p.maps_record_bytes / 1e6, p.maps_memory_mb);
    std::fprintf(o,
                 "fit: %sthe global fit below ran first on 1 pixel in %d along x and y "
                 "(--subsample %d: the records' budget, and at most %g M pixels, as its values "
                 "only start the texels and fill those the data do not determine), then the maps "
                 "on every pixel, band by band (--global with a global fit of your own "
                 "instead)\n",
                 records, p.global_subsample, p.global_subsample, kMapsGlobalPixels / 1e6);
  }
  if (!p.global_from.empty())
    std::fprintf(o, "fit: global fit from %s (--global: not fitted here); load %.3f s\n",
                 p.global_from.c_str(), p.seconds_load);
  else {
    char staged[96] = "";
    if (p.staged_stride > 1)
      std::snprintf(staged, sizeof staged, ", after %d on every %d%s pixel", p.staged_iterations,
                    p.staged_stride, ordinal_suffix(p.staged_stride));
    std::fprintf(
        o,
        "fit: %d iterations (%s%s), %s, loss %s, residual RMS %.3g, time %.3f s (load %.3f, "
        "start %.3f, solve %.3f, covariance %.3f by %s)\n",
        p.iterations, p.solver.c_str(), staged, p.termination.c_str(), p.loss.c_str(), p.rms,
        p.seconds, p.seconds_load, p.seconds_start, p.seconds_solve, p.seconds_covariance,
        p.covariance.c_str());
  }
  if (r.maps.w > 0) {
    size_t det = 0;
    std::vector<double> sp;
    for (size_t i = 0; i < r.maps.determined.size(); ++i)
      if (r.maps.determined[i]) ++det, sp.push_back(r.maps.psi_sigma_deg[i]);
    std::nth_element(sp.begin(), sp.begin() + static_cast<std::ptrdiff_t>(sp.size() / 2), sp.end());
    std::fprintf(o,
                 "fit: --maps %dx%d: %zu texels solved, %zu determined, median sigma of psi %.3g "
                 "deg, %.3f s\n",
                 r.maps.w, r.maps.h, r.maps.fitted, det, sp.empty() ? 0.0 : sp[sp.size() / 2],
                 r.maps.seconds);
    if (r.maps.smooth > 0)
      std::fprintf(o, "fit: --smooth %g: %d Jacobi sweeps (sigma from each texel's data alone)\n",
                   r.maps.smooth, r.maps.sweeps);
    if (p.fiber_order > 0 && p.fiber_order_errors.count > 0) {
      std::string by;
      for (int k = 1; k <= FiberOrderErrors::kMaxOrder; ++k)
        if (r.maps.texels_by_order[k] > 0)
          by += (by.empty() ? "" : ", ") + std::to_string(r.maps.texels_by_order[k]) +
                " at order " + std::to_string(k);
      std::fprintf(o,
                   "fit: --maps: fiber texels by quadrature order: %s (each the lowest its own "
                   "values allow, from the global fit's errors; at most its order %d)\n",
                   by.empty() ? "none solved" : by.c_str(), p.fiber_order);
    }
  }
  for (const auto& [k, why] : r.undetermined)
    std::fprintf(o, "fit: UNDETERMINED %s: %s\n", k.c_str(), why.c_str());
  for (const auto& s : p.model_summaries) std::fprintf(o, "fit: --model auto: %s\n", s.c_str());
  if (!p.model_selection.empty())
    std::fprintf(o, "fit: model selection: %s\n", p.model_selection.c_str());
  for (const auto& w : p.warnings) std::fprintf(o, "fit: WARNING: %s\n", w.text.c_str());
  for (const auto& n : p.notes) std::fprintf(o, "fit: note: %s\n", n.c_str());
}

// --tile i/N into the options.
template <class T>
void append_bytes(std::string* k, const T& v) {
  k->append(reinterpret_cast<const char*>(&v), sizeof v);
}

// A view's pose and camera, as bytes (exact equality: repeats and layouts are compared by them).
void append_view_camera(std::string* k, const ViewSpec& v) {
  append_bytes(k, v.world_from_camera.m);
  const Intrinsics& c = v.camera;
  for (double x : {double(c.width), double(c.height), c.fx, c.fy, c.cx, c.cy}) append_bytes(k, x);
  append_bytes(k, c.distortion);
}

// The views' cameras and poses (not their pixels, lights or file names), as a fingerprint.
std::string capture_layout(const CaptureSet& set) {
  std::string k = std::to_string(set.views.size());
  for (const ViewSpec& v : set.views) append_view_camera(&k, v);
  return text_fingerprint(k);
}

// Views that repeat an earlier one exactly (the same camera, pose, exposure, lights and geometry,
// and the same image file or bytes): removed from *set, their indices returned. A repeated view
// adds no information, but would count as new data and shrink every sigma by sqrt(copies).
std::vector<size_t> drop_repeated_views(CaptureSet* set) {
  std::map<std::string, std::vector<size_t>> by_key;  // view setup -> kept views with it
  std::vector<size_t> dropped;
  std::vector<ViewSpec> kept;
  for (size_t i = 0; i < set->views.size(); ++i) {
    const ViewSpec& v = set->views[i];
    std::string k;
    append_view_camera(&k, v);
    append_bytes(&k, v.exposure);
    for (const Light& l : v.lights) {
      append_bytes(&k, l.type);
      for (const Vec3& p : {l.position, l.direction})
        for (double x : {p.x, p.y, p.z}) append_bytes(&k, x);
      append_bytes(&k, l.intensity);
      append_bytes(&k, l.attenuation);
      append_bytes(&k, l.cutoff_deg);
      append_bytes(&k, l.exponent);
    }
    const GeometrySpec& g = v.geometry;
    for (const auto* s :
         {&g.position, &g.normal, &g.tangent, &g.mask, &g.uv, &g.topology, &g.mesh, &g.fiber_field})
      k += *s + '\0';
    const std::string image = join_path(set->dir, v.image);
    bool repeat = false;
    for (const size_t j : by_key[k]) {
      const std::string other = join_path(set->dir, kept[j].image);
      std::error_code ec;
      repeat = std::filesystem::equivalent(image, other, ec) ||
               (std::filesystem::file_size(image, ec) == std::filesystem::file_size(other, ec) &&
                read_text_file(image, size_t(1) << 32) == read_text_file(other, size_t(1) << 32));
      if (repeat) break;
    }
    if (repeat) {
      dropped.push_back(i);
      continue;
    }
    by_key[k].push_back(kept.size());
    kept.push_back(v);
  }
  if (!dropped.empty()) set->views = std::move(kept);
  return dropped;
}

// The options that change what a fit computes (not --threads, --tile, progress), as a fingerprint.
std::string options_fingerprint(const FitOptions& fo) {
  char text[512];
  std::snprintf(text, sizeof text,
                "model %d iso %d second %d subsample %d iterations %d loss %d order %d topo %d "
                "ceres %d %d maps %dx%d ceres %d smooth %.17g %d maps_iterations %d",
                static_cast<int>(fo.model), fo.fit_isotropic, fo.fit_second, fo.subsample,
                fo.max_iterations, static_cast<int>(fo.loss), fo.fiber_order, fo.topology_texels,
                fo.ceres_solver, fo.ceres_covariance, fo.maps_w, fo.maps_h, fo.maps_ceres,
                fo.maps_smooth, fo.maps_sweeps, fo.maps_iterations);
  return text_fingerprint(
      std::string(text) + (fo.keep_anisotropic ? " keep_anisotropic" : "") +
      (fo.lamps_from_highlight == LampsFromHighlight::kAlways  ? " lamps_from_highlight"
       : fo.lamps_from_highlight == LampsFromHighlight::kNever ? " lamps_as_imported"
                                                               : ""));
}

void parse_tile(const std::string& tile, FitOptions* fo) {
  const auto slash = tile.find('/');
  try {
    if (slash == std::string::npos) throw std::invalid_argument("no /");
    size_t used = 0;
    fo->tile_index = std::stoi(tile.substr(0, slash), &used);
    fo->tile_count = std::stoi(tile.substr(slash + 1));
  } catch (const std::exception&) {
    throw Error("fit: --tile must be i/N (e.g. 0/4), got '" + tile + "'");
  }
  if (fo->tile_count < 1 || fo->tile_index < 0 || fo->tile_index >= fo->tile_count)
    throw Error("fit: --tile i/N needs 0 <= i < N, got '" + tile + "'");
}

// --global FILE: the global fit an earlier `aniso fit` wrote.
void read_global(const std::string& path, FitOptions* fo) {
  fo->global = given_global(read_text_file(path), path, parent_dir(path));
}

bool g_mpi_rank = false;  // run_fit is one rank's tile of `fit --mpi`: no "then merge" hint

// `fit --mpi` in the plain binary: the same command line, run by `aniso-mpi` beside it.
[[noreturn]] void hand_over_to_mpi_build() {
  run_beside("aniso-mpi",
             "fit --mpi: this aniso was built without MPI (no aniso-mpi beside it): install "
             "openmpi-bin and libopenmpi-dev (scripts/install_deps.sh does) and configure with "
             "-DANISO_MPI=ON (scripts/build.sh does)");
}

// A private temporary folder, removed when this goes out of scope.
struct TempDir {
  std::string path;
  TempDir() {
    std::string t = (std::filesystem::temp_directory_path() / "aniso-mpi-XXXXXX").string();
    if (!::mkdtemp(t.data())) throw Error("fit --mpi: cannot make a temporary folder in " + t);
    path = t;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// `fit --mpi` without --global: rank 0 fits the global parameters once (as `aniso fit` without
// --maps) and every rank takes them as --global, so each keeps only the pixels of its own rows.
// False on the other ranks when rank 0 failed (rank 0 throws its message).
bool share_global_fit(const std::string& in, const MpiWorld* world, FitOptions* fo) {
  if (fo->model == FitModel::kAuto)
    throw Error(
        "fit --mpi: --maps fits the plain line model or the fiber model per texel: give "
        "--model line or fiber");
  bool ok = true;
  std::string bytes;  // the global fit as write_fit writes it (it has no maps)
  if (world->rank == 0) try {
      FitOptions g = *fo;
      g.maps_w = g.maps_h = 0;
      g.maps_smooth = 0;
      g.tile_index = g.tile_count = 0;
      g.test_isotropic = false;  // the texels' start: the anisotropic fit whatever BIC says
      g.psi_symmetry = PsiSymmetry::kNever;  // as a --maps fit's own global fit
      const FitResult r = fit_capture(read_capture(in), g);
      bytes = fit_text(r);
      std::printf(
          "fit --mpi: rank 0 fitted the global parameters (%d iterations, residual RMS %.3g, "
          "%.3f s); every rank fits its tile from them, keeping only the pixels of its rows\n",
          r.report.iterations, r.report.rms, r.report.seconds);
    } catch (const Error& e) {
      ok = false;
      bytes = e.what();
    }
  const auto [global_ok, global] = world->broadcast(ok, bytes);
  if (!global_ok) {
    if (world->rank == 0) throw Error("fit --mpi: the global fit: " + global);
    return false;
  }
  fo->global = given_global(global, "rank 0's global fit (fit --mpi)", parent_dir(in));
  return true;
}

// Every rank fits tile rank/size into its own temporary folder and sends the tile's bytes to
// rank 0, which writes them beside each other and merges them into --out. A rank that fails
// sends its message instead; rank 0 names it and nothing is written.
int run_fit_mpi(FitArgs& a) {
  const MpiWorld* world = mpi_world();
  if (!world) hand_over_to_mpi_build();
  if (a.fo.maps_w == 0)
    throw Error("fit --mpi: the ranks split the texels of a --maps fit: give --maps WxH");
  if (!a.tile.empty()) throw Error("fit --mpi: the ranks are the tiles: leave --tile out");
  if (a.out == "-")
    throw Error("fit --mpi: --maps writes map files beside the material: give --out a file");
  // The merged output must not replace an input: checked by every rank before any work.
  std::vector<std::string> outputs{a.out};
  if (lower_ext(a.in) != ".csv") {
    const CaptureSet set = read_capture(a.in);
    check_outputs_apart(outputs, capture_input_files(set));
  }
  check_output_file(a.out, OutputKind::kMaterial, a.force);
  if (world->rank != 0) {
    if (!std::freopen("/dev/null", "w", stdout)) return 1;  // rank 0 speaks for all
    a.fo.progress = nullptr;
  }
  g_mpi_rank = true;
  FitOptions fo = a.fo;
  if (!fo.global && !share_global_fit(a.in, world, &fo)) return 1;
  fo.tile_index = world->rank;
  fo.tile_count = world->size;
  bool ok = true;
  std::string bytes;
  try {
    const TempDir tmp;
    const std::string tile = tmp.path + "/tile.json";
    run_fit(a.in, fo, tile, a.truth);
    bytes = read_text_file(tile, size_t(1) << 36);  // a tile may pass 256 MB (a 1024^2 grid)
  } catch (const Error& e) {
    ok = false;
    bytes = e.what();
  }
  const auto all = world->gather(ok, bytes);
  if (world->rank != 0) return ok ? 0 : 1;
  for (size_t r = 0; r < all.size(); ++r)
    if (!all[r].first) throw Error("fit --mpi: rank " + std::to_string(r) + ": " + all[r].second);
  const TempDir tmp;
  std::vector<std::string> tiles;
  for (size_t r = 0; r < all.size(); ++r) {
    tiles.push_back(tmp.path + "/tile" + std::to_string(r) + ".json");
    write_text_file(tiles.back(), all[r].second);
  }
  check_outputs_apart(outputs, tiles);
  merge_maps_tiles(tiles, a.out, a.fo.maps_compression);
  std::printf("fit --mpi: %zu ranks, one tile each, merged -> %s (and its maps)\n", all.size(),
              a.out.c_str());
  return 0;
}

}  // namespace

// A fit of a measured file: its relative RMS error over the readings and per viewer angle of the
// file's grid, and, where the file is isotropic, no fiber direction (whatever the lobe's fit
// says, the file declares that there is none).
void measured_fit_report(const RglBsdf& b, const SampleTable& table, FitResult* r) {
  const TableMisfit misfit = table_misfit(r->material, table);
  r->report.measured_rel_rms = misfit.relative_rms;
  r->report.measured_median_rel = misfit.median_relative;
  r->report.measured_rel_rms_by_angle = misfit.relative_rms_by_theta_o;
  char buf[300];
  std::snprintf(buf, sizeof buf,
                "the fitted material against the file's readings: relative RMS %.3f, median "
                "reading's relative error %.3f (per viewer angle of the file's grid in "
                "report.measured)",
                r->report.measured_rel_rms, r->report.measured_median_rel);
  r->report.warnings.push_back(buf);
  if (b.isotropic() && !r->report.anisotropy.isotropic_written) {
    r->sigma.erase("fiber_angle_deg");
    r->undetermined["fiber_angle_deg"] =
        "the measured file is isotropic (its phi_i grid has " + std::to_string(b.phi_i().size()) +
        " value): a fiber direction fitted to it describes no anisotropy of the material";
    r->report.warnings.push_back(
        {"fiber_angle_deg: " + r->undetermined["fiber_angle_deg"], WarningAbout::kFiberAngle});
  }
}

namespace {

// run_fit, and with report_dir (--report) the page of what it wrote.
int fit_and_report(const std::string& input, const FitOptions& fo, const std::string& out,
                   const std::string& truth_path, const std::string& report_dir, bool force) {
  // Every input is read and checked before the (long) fit; the output never replaces one.
  std::vector<std::string> inputs{input};
  std::vector<size_t> repeated;  // views that repeat an earlier one, left out
  std::string truth = truth_path;
  CaptureSet set;
  SampleTable table;
  const bool is_bsdf = is_rgl_bsdf(input);
  const bool is_table = lower_ext(input) == ".csv" || is_bsdf;
  std::optional<RglBsdf> bsdf;
  if (is_bsdf) {
    bsdf = RglBsdf::read(input);
    table = measured_table(*bsdf);
    std::printf("fit: %s (%s): %s, %zu viewer directions; %zu readings on its own grid\n",
                input.c_str(), bsdf->description().c_str(),
                bsdf->isotropic() ? "isotropic" : "anisotropic",
                bsdf->theta_i().size() * bsdf->phi_i().size(), table.rows.size());
  } else if (is_table) {
    table = read_table(input);
  } else {
    set = read_capture(input);
    for (const auto& f : capture_input_files(set)) inputs.push_back(f);
    repeated = drop_repeated_views(&set);
    if (truth.empty() && !set.truth.empty()) truth = join_path(set.dir, set.truth);
  }
  if (fo.global) inputs.push_back(fo.global->file);
  Material truth_m;
  if (!truth.empty()) {
    truth_m = read_material(truth);
    inputs.push_back(truth);
  }
  std::vector<std::string> outputs{out};
  if (!report_dir.empty()) {
    if (out == "-" || fo.tile_count > 0)
      throw Error(
          "fit: --report writes a page of the material file: give --out a file (and "
          "report a tiled fit's merged material with aniso report)");
    outputs.push_back(report_dir);
  }
  if (fo.tile_count > 0 && fo.maps_w == 0)
    throw Error("fit: --tile splits a --maps fit: give --maps WxH");
  if (fo.maps_smooth > 0 && fo.maps_w == 0)
    throw Error("fit: --smooth couples the texels of a --maps fit: give --maps WxH");
  if ((fo.maps_w > 0 && fo.tile_count == 0) || fo.topology_texels > 0) {
    if (out == "-")
      throw Error(std::string("fit: ") + (fo.maps_w > 0 ? "--maps" : "--topology-map") +
                  " writes map files beside the material: give --out a file");
  }
  if (fo.tile_count > fo.maps_h && fo.maps_h > 0)
    throw Error("fit: --tile " + std::to_string(fo.tile_index) + "/" +
                std::to_string(fo.tile_count) + ": the --maps grid has " +
                std::to_string(fo.maps_h) + " texel rows, so at most " + std::to_string(fo.maps_h) +
                " tiles (each holds whole rows)");
  check_outputs_apart(outputs, inputs);
  check_output_file(out, fo.tile_count > 0 ? OutputKind::kMapsTile : OutputKind::kMaterial, force);
  if (!report_dir.empty()) check_output_folder(report_dir, OutputKind::kText, force);
  // What this fit read and how: a --global material must be of the same capture, and the tiles of
  // one merge must share both (merge compares them).
  const std::string capture_fp = is_table ? files_fingerprint({input}, parent_dir(input))
                                          : files_fingerprint(capture_input_files(set), set.dir);
  const std::string layout = is_table ? capture_fp : capture_layout(set);
  if (fo.global && !fo.global->capture_layout.empty() && fo.global->capture_layout != layout)
    throw Error("fit: --global " + fo.global->file + " was fitted to another capture (its " +
                "views' cameras and poses differ: report.capture_layout " +
                fo.global->capture_layout + ", this one's " + layout +
                "): give the material fitted to " + input + ", or leave --global out");
  FitResult r = is_table ? fit_table(table, fo) : fit_capture(set, fo);
  if (bsdf) measured_fit_report(*bsdf, table, &r);
  r.report.capture_fingerprint = capture_fp;
  r.report.capture_layout = layout;
  if (!repeated.empty()) {
    std::string list;
    for (size_t k = 0; k < repeated.size() && k < 10; ++k)
      list += (k ? ", " : "") + std::to_string(repeated[k]);
    if (repeated.size() > 10) list += ", ...";
    r.report.warnings.insert(
        r.report.warnings.begin(),
        std::to_string(repeated.size()) +
            " views repeat an earlier view exactly (the same camera, pose, exposure, lights and "
            "image): each was counted once, as repeats add no information but would shrink every "
            "sigma by sqrt(copies) (views " +
            list + " of " + input + ")");
  }
  r.report.options_fingerprint = options_fingerprint(fo);
  // With `--out -` the material goes to standard output: everything said goes to stderr.
  FILE* o = out == "-" ? stderr : stdout;
  if (fo.tile_count > 0) {
    write_maps_tile(out, r, fo);
    std::fprintf(o,
                 "fit: tile %d/%d: texel rows %d..%d of %dx%d, %zu texels solved in %.3f s, from "
                 "%zu pixels (%zu in other tiles' rows left out; load %.3f s) -> %s\n",
                 fo.tile_index, fo.tile_count, r.maps.row0, r.maps.row1 - 1, r.maps.w, r.maps.h,
                 r.maps.fitted, r.maps.seconds, r.report.pixels, r.report.outside_tile,
                 r.report.seconds_load, out.c_str());
    for (const std::string& w : r.report.warnings) std::fprintf(o, "fit: WARNING: %s\n", w.c_str());
    for (const std::string& n : r.report.notes) std::fprintf(o, "fit: note: %s\n", n.c_str());
    if (!g_mpi_rank) std::fprintf(o, "fit: then: aniso merge TILE.json... --out material.json\n");
    return 0;
  }
  write_fit(out, r, fo.maps_compression);
  print_report(o, r);
  // A plain --maps fit holds every pixel's record at once (for the global fit): say how to bound
  // that when it is more than the bands would hold.
  const double record_mb = 60e-6 * static_cast<double>(r.report.pixels);
  if (fo.maps_w > 0 && !fo.global && r.report.global_subsample == 0 &&
      record_mb > fo.maps_memory_mb)
    std::fprintf(o,
                 "fit: note: the maps held ~%.0f MB of records at once (every pixel, for the "
                 "global fit); given a global fit (--global %s: this one's global values), `fit "
                 "--maps` loads and fits band by band, at most --maps-memory (%g MB) at once\n",
                 record_mb, out.c_str(), fo.maps_memory_mb);
  std::fprintf(o, "fit: wrote %s\n", out.c_str());
  std::fprintf(o, "%s", describe_fit(r).c_str());
  if (!truth.empty()) {
    // A truth that varies over the sample is met texel by texel; its scalar values are only the
    // values its maps leave out, so one parameter set is not compared with them.
    if (r.maps.w > 0)
      std::fprintf(o, "against the truth (%s), texel by texel, %s", truth.c_str(),
                   compare_maps_to_truth(r, truth_m).c_str());
    if (truth_m.maps.any() && r.maps.w == 0)
      std::fprintf(o,
                   "against the truth (%s): it varies over the sample (maps), so one parameter "
                   "set is not compared with it; --maps WxH fits the sample texel by texel and "
                   "compares every texel with the truth there\n",
                   truth.c_str());
    if (!truth_m.maps.any())
      std::fprintf(o, "against the truth (%s):\n%s", truth.c_str(),
                   compare_to_truth(r, truth_m, nullptr).c_str());
  }
  if (!report_dir.empty()) {  // --report: aniso report of what was just written
    write_report({out, is_table ? "" : input, report_dir});
    std::fprintf(o, "fit: report: %s/index.html\n", report_dir.c_str());
  }
  return 0;
}

}  // namespace

int run_fit(const std::string& input, const FitOptions& fo, const std::string& out,
            const std::string& truth_path) {
  return fit_and_report(input, fo, out, truth_path, "", false);
}

// The options of --maps (per-texel maps, their solver, smoothing, tiles and MPI ranks).
void add_maps_options(CLI::App* fit, FitArgs* a) {
  FitOptions& fo = a->fo;
  fit->add_option(
      "--tile", a->tile,
      "with --maps: fit only tile i of N (bands of texel rows) and write a tile file "
      "to --out; `aniso merge` joins the tiles (the same maps as one run, bit for bit)");
  fit->add_option("--maps-solver", a->maps_solver,
                  "--maps: lm (a hand-written Levenberg-Marquardt per texel, the default) or "
                  "ceres (one Ceres problem per texel: the reference, slower)")
      ->check(CLI::IsMember({"lm", "ceres"}))
      ->default_str("lm");
  fit->add_option("--maps-lanes", a->maps_lanes,
                  "--maps, line model: the texels' float passes 8 floats a register (AVX2) or 16 "
                  "(AVX-512); auto: the widest this CPU has. The two agree to float's rounding "
                  "(~1e-3 sigma), not bit for bit: 8 reproduces a machine without AVX-512 "
                  "(report.maps_float_lanes says which ran)")
      ->check(CLI::IsMember({"auto", "8", "16"}))
      ->default_str("auto");
  add_exr_compression(fit, &a->compression,
                      "--maps' files (a 1024^2 map's 10 files: 80 MB as none)");
  fit->add_option("--smooth", fo.maps_smooth,
                  "--maps: pull every texel toward its 4 neighbours with weight lambda, in units "
                  "of the texel's own data (1: a neighbour one sigma away weighs as much as "
                  "moving one sigma off the texel's own best fit; 0: every texel alone)")
      ->check(CLI::Range(0.0, 1e6));
  fit->add_option("--smooth-sweeps", fo.maps_sweeps,
                  "--smooth: Jacobi sweeps over the grid (each texel sees its neighbours' values "
                  "of the sweep before; a pull reaches this many texels)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  fit->add_option("--maps-iterations", fo.maps_iterations,
                  "--maps: iterations each texel's solver may take; a texel still moving then is "
                  "counted, warned about and marked undetermined (the global values kept)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  fit->add_option("--maps-memory", fo.maps_memory_mb,
                  "--maps: the records (60 bytes a pixel and light) held at once, in MB; with "
                  "--global the texel rows are fitted in as many bands as that takes, each band "
                  "reading only its rows of the views (the same maps as one band, bit for bit), "
                  "and, where the views share one geometry (a fixed camera), at most " +
                      millions(kMapsSharedBandBytes) +
                      " MB of its pixels a band, which every view reads again (in cache, not from "
                      "memory); "
                      "without, where every pixel's records would pass it or the sample has more "
                      "than " +
                      millions(kMapsGlobalPixels) +
                      " M pixels, the global fit runs first on a --subsample that fits both, then "
                      "the maps in bands")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 1e9));
  fit->add_option("--global", a->global,
                  "--maps: take the global fit (every texel's start, and the values of texels the "
                  "data do not determine) from this material, an earlier `aniso fit` of the same "
                  "capture (a --subsample of it will do), instead of fitting it; the maps are "
                  "then loaded and fitted band by band of texel rows (--maps-memory), and with "
                  "--tile the tile reads and keeps only the pixels whose uv falls in its rows: "
                  "its memory is its share of the sample");
  fit->add_flag("--mpi", a->mpi,
                "with --maps, under mpirun: every rank fits one tile of the texels (rank i of N "
                "is tile i/N) and rank 0 merges them into --out (the same files as one run). "
                "E.g. mpirun -np 4 aniso fit CAPTURE --maps 256x256 --mpi --out m.json");
  fit->add_option(
      "--maps", a->maps,
      "also fit per-texel maps of k_d, k_s, n and the fiber direction (and, with "
      "--model fiber, the topology s of a flat sample or, where the set has a "
      "topology map, its amplitude A), WxH texels over the sample's "
      "uv (written beside --out as EXR, docs/formats.md \"Material maps\", with per-texel "
      "sigma, coverage, a determined mask and each texel's residual RMS; texels "
      "whose residual is over twice the images' noise are named)");
}

Command add_fit(CLI::App& app) {
  auto a = std::make_shared<FitArgs>();
  auto* fit =
      app.add_subcommand("fit", "Fit model parameters to a capture set or a sample table (CSV)");
  FitOptions& fo = a->fo;
  fit->add_option("CAPTURE", a->in, "capture folder, its capture.json, or a sample table .csv")
      ->required();
  const std::map<std::string, FitModel> models{
      {"line", FitModel::kLine}, {"fiber", FitModel::kFiber}, {"auto", FitModel::kAuto}};
  fit->add_option("--model", fo.model,
                  "model to fit: line, fiber, or auto (both; the lower BIC is kept)")
      ->default_str("line")
      ->transform(CLI::CheckedTransformer(models))
      ->option_text("line|fiber|auto (default line)");
  fit->add_option("--out", a->out, "material file to write ('-' = standard output)")->required();
  fit->add_option("--report", a->report,
                  "also write the fit as a page (DIR/index.html), as `aniso report` does with "
                  "this capture");
  add_force_flag(fit, &a->force);
  fit->add_option(
      "--truth", a->truth,
      "ground-truth material: print every parameter's error (default: the set's truth)");
  fit->add_option("--subsample", fo.subsample, "use every k-th pixel in x and y")
      ->capture_default_str()
      ->check(CLI::Range(1, 1024));
  const std::map<std::string, FitLoss> losses{
      {"huber", FitLoss::kHuber}, {"cauchy", FitLoss::kCauchy}, {"none", FitLoss::kNone}};
  fit->add_option("--loss", fo.loss,
                  "robust loss: huber, cauchy or none, scaled to 3 robust sigmas of the residuals")
      ->default_str("huber")
      ->transform(CLI::CheckedTransformer(losses))
      ->option_text("huber|cauchy|none (default huber)");
  fit->add_flag("--fit-isotropic", fo.fit_isotropic,
                "also fit the isotropic (Lambert + Blinn-Phong) term");
  auto* from_highlight = fit->add_flag_callback(
      "--lamps-from-highlight", [&fo] { fo.lamps_from_highlight = LampsFromHighlight::kAlways; },
      "place each photo's point lamp again by the sample's own highlight, its position fitted "
      "together with the line model's material (the position import found, within its sigma, as "
      "the prior), then fit under the lamps found; the report lists each lamp as given and as "
      "found, and names a lamp the highlight moves more than 5 sigmas. The default for a capture "
      "whose lamps state their sigma (an imported shoot) where the fit can (line model, not "
      "--global or --tile); this flag makes it an error where it cannot");
  fit->add_flag_callback(
         "--lamps-as-imported", [&fo] { fo.lamps_from_highlight = LampsFromHighlight::kNever; },
         "fit under the lamps as the capture gives them (as import placed them from the board's "
         "paper), without placing them again by the highlight")
      ->excludes(from_highlight);
  const std::map<std::string, PsiSymmetry> symmetries{{"auto", PsiSymmetry::kAuto},
                                                      {"always", PsiSymmetry::kAlways},
                                                      {"never", PsiSymmetry::kNever}};
  fit->add_option("--psi-from-symmetry", fo.psi_symmetry,
                  "the line model's fiber direction placed again by the highlight's mirror "
                  "symmetry alone, whatever the lobe's shape (a jackknife over views its sigma), "
                  "and taken with the other numbers fitted under it where it is surer than the "
                  "model's own: auto (where the model misses the data), always, never")
      ->default_str("auto")
      ->transform(CLI::CheckedTransformer(symmetries))
      ->option_text("auto|always|never (default auto)");
  fit->add_flag("--keep-anisotropic", fo.keep_anisotropic,
                "where the isotropic part alone (Lambert + Blinn-Phong) fits the data better by "
                "BIC, keep the anisotropic fit (its fiber direction marked undetermined) instead "
                "of writing the isotropic material");
  fit->add_flag("--fit-second-fiber", fo.fit_second,
                "also fit a second fiber direction and its weight (woven cloth)");
  fit->add_option("--topology-map", fo.topology_texels,
                  "fiber model: fit a per-texel map of s, N x N texels over uv (written beside "
                  "--out as an EXR)")
      ->check(CLI::Range(2, 256));
  fit->add_flag("--ceres-covariance", fo.ceres_covariance,
                "uncertainty by Ceres' dense SVD of the whole Jacobian (the reference; slower and "
                "larger) instead of the normal equations accumulated in one pass");
  fit->add_option("--solver", a->solver,
                  "line and fiber models: fused (one pass over the observations per "
                  "Levenberg-Marquardt step, the default) or ceres (the fitter of record, the "
                  "reference the tests compare with; also what the optional terms and a texel "
                  "map of s use)")
      ->check(CLI::IsMember({"fused", "ceres"}))
      ->default_str("fused");
  fit->add_option("--threads", fo.threads,
                  "threads for every phase of the fit: loading the views, the solve, the maps' "
                  "texels (default: the cores this process may use)")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  fit->add_option("--fiber-order", fo.fiber_order,
                  "fiber model: Gauss-Legendre nodes per panel of the specular integral (the "
                  "panels sit at multiples of the lobe's width around its peak); default: the "
                  "smallest of 3, 4, 6, 8, 12 whose error stays under 1 % of the images' noise / "
                  "sqrt(values) (8 without a noise estimate)")
      ->check(CLI::Range(1, 16));
  fit->add_option("--max-iterations", fo.max_iterations, "solver iterations")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  add_maps_options(fit, a.get());
  return {fit, [a, fit] {
            if (!a->maps.empty()) parse_size(a->maps, &a->fo.maps_w, &a->fo.maps_h, "--maps");
            a->fo.maps_compression = exr_compression_named(a->compression);
            a->fo.maps_ceres = a->maps_solver == "ceres";
            a->fo.maps_lanes = a->maps_lanes == "auto" ? 0 : std::stoi(a->maps_lanes);
            a->fo.ceres_solver = a->solver == "ceres";
            if (!a->tile.empty()) parse_tile(a->tile, &a->fo);
            if (!a->global.empty()) {
              read_global(a->global, &a->fo);
              if (fit->get_option("--model")->count() == 0)
                a->fo.model = a->fo.global->material.fiber() ? FitModel::kFiber : FitModel::kLine;
            }
            if (a->mpi) return run_fit_mpi(*a);
            return fit_and_report(a->in, a->fo, a->out, a->truth, a->report, a->force);
          }};
}

}  // namespace aniso::cli
