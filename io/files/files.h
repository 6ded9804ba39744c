// Files and folders the tool writes, and the rules that keep a person's files safe
// (docs/files.md; tests/test_files.cpp):
//
//  - Every output has a kind (OutputKind). A folder output records its kind and every file it
//    wrote (path, size, modification time) in its marker file; a file output carries its kind in
//    a stamp inside the file ("aniso KIND": a JSON key, a PNG text chunk, an EXR attribute, a
//    JPEG comment). An output replaces only an earlier output of its own kind that still holds
//    exactly what aniso wrote; anything else is refused, naming the file, before the work starts.
//  - `force` (an output's own, given where it is claimed): what would be refused is moved aside
//  (NAME.aniso-old-N), never deleted; the files an
//    earlier output of the same kind wrote, unchanged, are replaced.
//  - A file output is written to a temporary sibling and renamed over the target in one step, so
//    a failed or killed run leaves the previous file as it was. A replaced file keeps its mode
//    (and its owner where the process may set it). Every write is checked.
//  - "-" means standard output. A target that exists and is not a regular file (a device, a FIFO,
//    the pipe behind /dev/stdout) is written in place, never renamed over. A folder is refused.
//  - A folder output is written beside the target and swapped in with one atomic exchange
//    (renameat2 RENAME_EXCHANGE); the earlier output's recorded files are then removed, and
//    anything else found in it is moved aside, never deleted.
//  - Temporaries of killed runs (named after their dead process) are cleaned by the next run that
//    writes the same target, by the same rule: aniso's own files go, anything else is moved aside.
//  - An output never replaces an input of the same command (check_outputs_apart).
#pragma once
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace aniso {

// The marker file inside every folder this tool writes.
inline constexpr const char* kOutputMarker = ".aniso-output";

// What an output is. Its name ("bake", "material", ...) is what the marker and the stamps record.
enum class OutputKind {
  kCapture,          // synth
  kImportedCapture,  // import
  kPhotoShoot,       // synth --photos
  kBake,
  kExport,
  kResiduals,   // verify --residuals
  kBenchWork,   // bench --work: the bench's own folder, whose content changes run to run
  kMaterial,    // fit, merge
  kMapsTile,    // fit --tile
  kTable,       // eval: a CSV carries no stamp, so an existing one is replaced only with force
  kShoot,       // board --shoot: a skeleton a person fills in, so never replaced without force
  kPreview,     // preview --out
  kBoard,       // board --out
  kScreenshot,  // view --screenshot
  kBenchResult,
  kText,  // anything else a person names (reports, sweeps)
};
const char* kind_name(OutputKind kind);
// Whether a file of this kind carries a stamp (a table and a shoot do not: never replaced).
bool stamped(OutputKind kind);

// The text a file output of this path carries as its stamp: "aniso KIND" where the path was
// claimed by check_output_file, "aniso" otherwise (files inside a folder output).
std::string output_stamp(const std::string& path);
// The same, empty for a path not claimed or of a kind that carries none (a JSON output's
// "written_by" key).
std::string json_stamp(const std::string& path);
// The kind an existing file's stamp names ("material", "preview", ...; "" for a file that
// carries no aniso stamp, or "aniso" for one with the stamp but no kind).
std::string stamped_kind(const std::string& path);

// Calls write(tmp) and moves the result to `path` (see the rules above); removes tmp and
// rethrows if write throws. `write` must write a file at exactly the path it is given.
void write_atomically(const std::string& path,
                      const std::function<void(const std::string&)>& write);

void write_text_file(const std::string& path, const std::string& text);

// Receives a file's bytes in order, piece by piece.
using ByteSink = std::function<void(const char* data, size_t size)>;
// Writes `path` atomically from the pieces `produce` hands its sink, each as it comes: nothing the
// size of the file is held in memory.
void write_file_pieces(const std::string& path,
                       const std::function<void(const ByteSink&)>& produce);

// Reads a regular file of at most `max_bytes` (default 256 MiB); anything else (missing, a
// folder, a device, a FIFO, too large) is an error naming the file.
std::string read_text_file(const std::string& path, size_t max_bytes = size_t(256) << 20);
// The same into *out, whose allocation is kept where it is large enough (a buffer reused file
// after file touches no fresh pages).
void read_file_into(const std::string& path, size_t max_bytes, std::string* out);

// Throws unless `dir` may be (re)written by a folder output of `kind`: it does not exist, is an
// empty folder, or is an earlier output of that kind holding exactly the files it recorded. With
// `force` anything passes (it is moved aside when the folder is written). Also throws when the
// folder could not be created or written. Claims the folder: a later check of it (the library's,
// before it writes) keeps the force given here. Call it before a long run.
void check_output_folder(const std::string& dir, OutputKind kind, bool force = false);

// Writes a whole folder: fill(tmp_dir), then the marker (kind and files), then one atomic swap
// into place. While fill runs, files written under tmp_dir go straight to their names (the folder
// is private and is discarded whole if fill fails): no per-file temporary and rename.
void write_folder_atomically(const std::string& dir, OutputKind kind,
                             const std::function<void(const std::string&)>& fill);

// Writes `dir`'s marker: an output of `kind` holding the files there now.
void mark_folder(const std::string& dir, OutputKind kind);

// Throws unless `path` may be written as a file output of `kind`: it does not exist, is "-" or a
// device or FIFO, or is a file whose stamp names the same kind; with `force` any file (moved
// aside when written). Also throws when its folder could not be created or written. Claims the
// path: its stamp, its force and the same check at the moment it is replaced follow from here.
// Call it before a long run.
void check_output_file(const std::string& path, OutputKind kind, bool force = false);

// The files that belong with one output file `owner` (a material's maps), written as one
// generation: fill(dir) writes them under plain names ("m_kd.exr") into a private folder beside
// `owner`; each then moves beside `owner` as STEM.GEN.EXT ("m_kd.1f3a9c07.exr"), GEN the first 8
// hex digits of a hash of all their bytes (the same bytes give the same names), never replacing
// a file. Returns plain name -> the name it has beside `owner`. Write `owner` naming them after
// this, and remove the earlier generation (remove_generation) last: whatever kills or fills the
// run, the owner read back names files of one run.
std::map<std::string, std::string> write_generation(
    const std::string& owner, const std::function<void(const std::string&)>& fill);
// 16 hex digits that tell one set of input files from another: each file's name relative to
// `base`, its size, and its first and last 64 KiB (copies of a capture elsewhere agree).
std::string files_fingerprint(const std::vector<std::string>& files, const std::string& base);
// 16 hex digits of a hash of `text`.
std::string text_fingerprint(const std::string& text);

// Whether `name` has the form write_generation gives (STEM.GEN.EXT, GEN 8 hex digits).
bool is_generation_name(const std::string& name);
// Removes the files `names` (relative to `owner`'s folder) of an earlier generation that `keep`
// does not hold: only names of write_generation's form, and only EXR and PNG files whose stamp
// says aniso wrote them.
void remove_generation(const std::string& owner, const std::vector<std::string>& names,
                       const std::vector<std::string>& keep);

// Throws if an output (a file, or a folder that would be replaced) is, or contains, one of the
// inputs: "OUT: is an input of this command (IN); choose another --out".
void check_outputs_apart(const std::vector<std::string>& outputs,
                         const std::vector<std::string>& inputs);

std::string join_path(const std::string& dir, const std::string& rel);
std::string parent_dir(const std::string& path);
std::string lower_ext(const std::string& path);
// `path` relative to the folder `base` (both may be relative to the working directory).
std::string relative_to(const std::string& path, const std::string& base);
// The executable `name` in the folder of the running program (/proc/self/exe), or "" when there
// is none (or it may not be run).
std::string program_beside_self(const std::string& name);

}  // namespace aniso
