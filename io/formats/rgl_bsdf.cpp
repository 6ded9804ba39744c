#include "io/formats/rgl_bsdf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>

#include "core/error.h"

namespace aniso {

namespace {

constexpr float kPi = 3.14159265358979323846f;

// The tensor file: "tensor_file\0", version 1.0, a field count, then per field its name, rank,
// element type, byte offset and shape; the data at the offsets.
enum DType : uint8_t {
  kInvalid = 0,
  kUInt8,
  kInt8,
  kUInt16,
  kInt16,
  kUInt32,
  kInt32,
  kUInt64,
  kInt64,
  kFloat16,
  kFloat32,
  kFloat64
};
size_t dtype_bytes(uint8_t t) {
  static constexpr size_t kBytes[] = {0, 1, 1, 2, 2, 4, 4, 8, 8, 2, 4, 8};
  return t <= kFloat64 ? kBytes[t] : 0;
}

struct Field {
  uint8_t dtype = kInvalid;
  uint64_t offset = 0, bytes = 0;
  std::vector<uint64_t> shape;
};

class Reader {
 public:
  Reader(const std::string& bytes, const std::string& path) : b_(bytes), path_(path) {}
  template <class T>
  T get(const char* what) {
    if (at_ + sizeof(T) > b_.size()) fail(std::string("truncated in the header (") + what + ")");
    T v;
    std::memcpy(&v, b_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  std::string text(size_t n, const char* what) {
    if (at_ + n > b_.size()) fail(std::string("truncated in the header (") + what + ")");
    std::string s = b_.substr(at_, n);
    at_ += n;
    return s;
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw Error(path_ + ": not a readable RGL .bsdf tensor file: " + why);
  }

 private:
  const std::string& b_;
  const std::string& path_;
  size_t at_ = 0;
};

// A float32 field of the expected rank, its values checked finite.
std::vector<float> floats(const std::string& bytes, const std::map<std::string, Field>& fields,
                          const std::string& name, size_t rank, const std::string& path,
                          std::vector<uint64_t>* shape) {
  const auto it = fields.find(name);
  if (it == fields.end())
    throw Error(path + ": field \"" + name +
                "\" is missing (an RGL material-database file has "
                "theta_i, phi_i, ndf, sigma, vndf, luminance, rgb, description and jacobian)");
  const Field& f = it->second;
  if (f.dtype != kFloat32 || f.shape.size() != rank)
    throw Error(path + ": field \"" + name + "\": expected float32 of rank " +
                std::to_string(rank) + ", found type " + std::to_string(f.dtype) + " of rank " +
                std::to_string(f.shape.size()));
  std::vector<float> v(f.bytes / 4);
  std::memcpy(v.data(), bytes.data() + f.offset, f.bytes);
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      throw Error(path + ": field \"" + name + "\" holds a value that is not finite (element " +
                  std::to_string(i) + ")");
  *shape = f.shape;
  return v;
}

// powitacq's interval search: the i in [0, size - 2] with pred(i) true and pred(i + 1) false,
// clamped at both ends.
template <class Pred>
uint32_t find_interval(uint32_t size, const Pred& pred) {
  int64_t n = static_cast<int64_t>(size) - 2, first = 1;
  while (n > 0) {
    const int64_t half = n >> 1, middle = first + half;
    if (pred(static_cast<uint32_t>(middle)))
      first = middle + 1, n -= half + 1;
    else
      n = half;
  }
  return static_cast<uint32_t>(std::clamp<int64_t>(first - 1, 0, static_cast<int64_t>(size) - 2));
}

float elevation(float x, float y, float z) {
  return 2.f * std::asin(.5f * std::sqrt(x * x + y * y + (z - 1.f) * (z - 1.f)));
}
float theta2u(float theta) { return std::sqrt(theta * (2.f / kPi)); }
float phi2u(float phi) { return (phi + kPi) / (2.f * kPi); }

}  // namespace

void RglBsdf::Grid::build(uint32_t gx, uint32_t gy, const float* values,
                          const std::vector<std::vector<float>>& params, bool with_cdf) {
  nx = gx, ny = gy;
  const size_t D = params.size();
  param_size.assign(D, 0), param_stride.assign(D, 0), param_values = params;
  uint32_t slices = 1;
  for (size_t k = D; k-- > 0;) {
    param_size[k] = static_cast<uint32_t>(params[k].size());
    param_stride[k] = param_size[k] > 1 ? slices : 0;
    slices *= param_size[k];
  }
  const size_t n = static_cast<size_t>(nx) * ny;
  data.resize(slices * n);
  if (!with_cdf) {  // kept as they are (eval's scale by the patch count undoes this one)
    const float scale = 1.f / (static_cast<float>(nx - 1) * static_cast<float>(ny - 1));
    for (size_t i = 0; i < data.size(); ++i) data[i] = values[i] * scale;
    return;
  }
  marginal_cdf.resize(slices * ny);
  conditional_cdf.resize(slices * n);
  for (uint32_t s = 0; s < slices; ++s) {
    const float* in = values + s * n;
    float* cond = conditional_cdf.data() + s * n;
    float* marg = marginal_cdf.data() + s * ny;
    for (uint32_t y = 0; y < ny; ++y) {  // each row's cdf, trapezoids in double
      double sum = 0;
      const size_t row = static_cast<size_t>(y) * nx;
      cond[row] = 0;
      for (uint32_t x = 0; x + 1 < nx; ++x) {
        sum += .5 * (static_cast<double>(in[row + x]) + in[row + x + 1]);
        cond[row + x + 1] = static_cast<float>(sum);
      }
    }
    marg[0] = 0;
    double sum = 0;
    for (uint32_t y = 0; y + 1 < ny; ++y) {
      sum += .5 * (static_cast<double>(cond[(y + 1) * static_cast<size_t>(nx) - 1]) +
                   cond[(y + 2) * static_cast<size_t>(nx) - 1]);
      marg[y + 1] = static_cast<float>(sum);
    }
    const float norm = 1.f / marg[ny - 1];
    for (size_t i = 0; i < n; ++i) cond[i] *= norm, data[s * n + i] = in[i] * norm;
    for (uint32_t i = 0; i < ny; ++i) marg[i] *= norm;
  }
}

RglBsdf::Grid::Weights RglBsdf::Grid::weights(const float* param) const {
  Weights w;
  for (size_t d = 0; d < param_size.size(); ++d) {
    if (param_size[d] == 1) {
      w.w[2 * d] = 1, w.w[2 * d + 1] = 0;
      continue;
    }
    const std::vector<float>& v = param_values[d];
    const uint32_t i = find_interval(param_size[d], [&](uint32_t k) { return v[k] <= param[d]; });
    const float p0 = v[i], p1 = v[i + 1];
    w.w[2 * d + 1] = std::clamp((param[d] - p0) / (p1 - p0), 0.f, 1.f);
    w.w[2 * d] = 1.f - w.w[2 * d + 1];
    w.slice += param_stride[d] * i;
  }
  return w;
}

// The value at `index` interpolated over parameters [0, dim): the last one outermost.
float RglBsdf::Grid::lookup(const float* base, uint32_t index, uint32_t size, const Weights& w,
                            size_t dim) const {
  if (dim == 0) return base[index];
  const uint32_t i1 = index + param_stride[dim - 1] * size;
  const float v0 = lookup(base, index, size, w, dim - 1), v1 = lookup(base, i1, size, w, dim - 1);
  return std::fma(v0, w.w[2 * dim - 2], v1 * w.w[2 * dim - 1]);
}

float RglBsdf::Grid::eval(float x, float y, const float* param) const {
  const Weights w = weights(param);
  const size_t D = param_size.size();
  const float px = x * static_cast<float>(nx - 1), py = y * static_cast<float>(ny - 1);
  const uint32_t ox = std::min(static_cast<uint32_t>(px), nx - 2),
                 oy = std::min(static_cast<uint32_t>(py), ny - 2);
  const float w1x = px - static_cast<float>(ox), w1y = py - static_cast<float>(oy);
  const float w0x = 1.f - w1x, w0y = 1.f - w1y;
  const uint32_t size = nx * ny, index = ox + oy * nx + w.slice * size;
  const float* d = data.data();
  const float v00 = lookup(d, index, size, w, D), v10 = lookup(d + 1, index, size, w, D),
              v01 = lookup(d + nx, index, size, w, D), v11 = lookup(d + nx + 1, index, size, w, D);
  return std::fma(w0y, std::fma(w0x, v00, w1x * v10), w1y * std::fma(w0x, v01, w1x * v11)) *
         (static_cast<float>(nx - 1) * static_cast<float>(ny - 1));
}

void RglBsdf::Grid::invert(float* x, float* y, const float* param) const {
  const Weights w = weights(param);
  const size_t D = param_size.size();
  float sx = *x * static_cast<float>(nx - 1), sy = *y * static_cast<float>(ny - 1);
  const uint32_t px = std::min(static_cast<uint32_t>(sx), nx - 2),
                 py = std::min(static_cast<uint32_t>(sy), ny - 2);
  sx -= static_cast<float>(px), sy -= static_cast<float>(py);
  const uint32_t size = nx * ny;
  uint32_t offset = px + py * nx + w.slice * size;
  const float* d = data.data();
  const float v00 = lookup(d, offset, size, w, D), v10 = lookup(d + 1, offset, size, w, D),
              v01 = lookup(d + nx, offset, size, w, D),
              v11 = lookup(d + nx + 1, offset, size, w, D);
  const float c0 = std::fma(1.f - sy, v00, sy * v01), c1 = std::fma(1.f - sy, v10, sy * v11);
  sx *= c0 + .5f * sx * (c1 - c0);
  const float* cond = conditional_cdf.data();
  const float u0 = lookup(cond, offset, size, w, D), u1 = lookup(cond + nx, offset, size, w, D);
  sx += (1.f - sy) * u0 + sy * u1;
  offset = py * nx + w.slice * size;
  const float r0 = lookup(cond, offset + nx - 1, size, w, D),
              r1 = lookup(cond, offset + 2 * nx - 1, size, w, D);
  sx /= (1.f - sy) * r0 + sy * r1;
  sy *= r0 + .5f * sy * (r1 - r0);
  sy += lookup(marginal_cdf.data(), py + w.slice * ny, ny, w, D);
  *x = sx, *y = sy;
}

RglBsdf RglBsdf::read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  in.seekg(0, std::ios::end);
  const std::streamoff total = in.tellg();
  constexpr std::streamoff kMaxBytes = std::streamoff{4}
                                       << 30;  // the largest database file: 0.3 GB
  if (total < 18)
    throw Error(path + ": not an RGL .bsdf tensor file: " + std::to_string(total) +
                " bytes, too small for its header");
  if (total > kMaxBytes) throw Error(path + ": over 4 GiB: not an RGL material-database file");
  std::string bytes(static_cast<size_t>(total), '\0');
  in.seekg(0);
  in.read(bytes.data(), total);
  if (!in) throw Error(path + ": read failed");
  Reader r(bytes, path);
  if (r.text(12, "magic") != std::string("tensor_file\0", 12))
    r.fail("its first 12 bytes are not \"tensor_file\"");
  const uint8_t major = r.get<uint8_t>("version"), minor = r.get<uint8_t>("version");
  if (major != 1 || minor != 0)
    r.fail("version " + std::to_string(major) + "." + std::to_string(minor) +
           " (this reader: 1.0)");
  const uint32_t count = r.get<uint32_t>("field count");
  constexpr uint32_t kMaxFields = 256;
  if (count > kMaxFields) r.fail(std::to_string(count) + " fields");
  std::map<std::string, Field> fields;
  for (uint32_t i = 0; i < count; ++i) {
    const uint16_t name_len = r.get<uint16_t>("field name length");
    const std::string name = r.text(name_len, "field name");
    Field f;
    const uint16_t rank = r.get<uint16_t>("field rank");
    f.dtype = r.get<uint8_t>("field type");
    f.offset = r.get<uint64_t>("field offset");
    if (rank > 8) r.fail("field \"" + name + "\" has rank " + std::to_string(rank));
    if (f.dtype == kInvalid || f.dtype > kFloat64)
      r.fail("field \"" + name + "\" has an unknown type " + std::to_string(f.dtype));
    uint64_t bytes_needed = dtype_bytes(f.dtype);
    for (uint16_t k = 0; k < rank; ++k) {
      const uint64_t n = r.get<uint64_t>("field shape");
      // Every product stays within the file's size, so nothing past it is ever allocated.
      if (n > static_cast<uint64_t>(total) ||
          (n > 0 && bytes_needed > static_cast<uint64_t>(total) / n))
        r.fail("field \"" + name + "\": its shape holds more bytes than the whole file (" +
               std::to_string(total) + " bytes): truncated, or a corrupt shape");
      f.shape.push_back(n);
      bytes_needed *= n;
    }
    f.bytes = bytes_needed;
    if (f.offset > static_cast<uint64_t>(total) ||
        f.bytes > static_cast<uint64_t>(total) - f.offset)
      r.fail("field \"" + name + "\": its data (" + std::to_string(f.bytes) + " bytes at " +
             std::to_string(f.offset) + ") run past the end of the file (" + std::to_string(total) +
             " bytes): truncated?");
    fields[name] = f;
  }
  // A spectral file has "spectra" over "wavelengths" where an RGB one has "rgb".
  const bool spectral = fields.count("spectra") && !fields.count("rgb");
  const char* values = spectral ? "spectra" : "rgb";
  RglBsdf b;
  std::vector<uint64_t> s_theta, s_phi, s_ndf, s_sigma, s_vndf, s_rgb, s_wl;
  b.theta_i_ = floats(bytes, fields, "theta_i", 1, path, &s_theta);
  b.phi_i_ = floats(bytes, fields, "phi_i", 1, path, &s_phi);
  const std::vector<float> ndf = floats(bytes, fields, "ndf", 2, path, &s_ndf);
  const std::vector<float> sigma = floats(bytes, fields, "sigma", 2, path, &s_sigma);
  const std::vector<float> vndf = floats(bytes, fields, "vndf", 4, path, &s_vndf);
  const std::vector<float> rgb = floats(bytes, fields, values, 5, path, &s_rgb);
  std::vector<float> channels{0.f, 1.f, 2.f};
  if (spectral) {
    b.wavelengths_ = floats(bytes, fields, "wavelengths", 1, path, &s_wl);
    channels = b.wavelengths_;
  }
  auto bad = [&](const std::string& what) {
    throw Error(path + ": " + what + " (an RGL material-database file's fields disagree)");
  };
  const uint64_t nt = s_theta[0], np = s_phi[0];
  if (nt < 2 || np < 1) bad("theta_i needs at least 2 values and phi_i 1");
  for (const auto* v : {&b.theta_i_, &b.phi_i_, &b.wavelengths_})
    for (size_t i = 1; i < v->size(); ++i)
      if (!((*v)[i] > (*v)[i - 1]))
        bad(std::string(v == &b.theta_i_ ? "theta_i"
                        : v == &b.phi_i_ ? "phi_i"
                                         : "wavelengths") +
            " is not increasing");
  for (const auto* s : {&s_ndf, &s_sigma})
    if ((*s)[0] < 2 || (*s)[1] < 2) bad("ndf and sigma need at least 2 x 2 values");
  if (s_vndf[0] != np || s_vndf[1] != nt || s_vndf[2] < 2 || s_vndf[3] < 2)
    bad("vndf's shape is not [phi_i, theta_i, >= 2, >= 2]");
  if (spectral && s_wl[0] < 1) bad("wavelengths is empty");
  if (s_rgb[0] != np || s_rgb[1] != nt || s_rgb[2] != channels.size() || s_rgb[3] < 2 ||
      s_rgb[4] < 2)
    bad(spectral ? "spectra's shape is not [phi_i, theta_i, wavelengths, >= 2, >= 2]"
                 : "rgb's shape is not [phi_i, theta_i, 3, >= 2, >= 2]");
  if (spectral) {
    try {
      b.rgb_weights_ = spectrum_rgb_weights(b.wavelengths_);
    } catch (const Error& e) {
      throw Error(path + ": " + e.what());
    }
  }
  if (fields.count("description") && fields.at("description").dtype == kUInt8) {
    const Field& d = fields.at("description");
    b.description_ = bytes.substr(d.offset, d.bytes);
  }
  b.isotropic_ = np <= 2;
  if (!b.isotropic_ && std::lrint(2 * kPi / (b.phi_i_.back() - b.phi_i_.front())) != 1)
    bad("phi_i covers a fraction of the circle (a reduced symmetry this reader does not take)");
  b.ndf_.build(static_cast<uint32_t>(s_ndf[1]), static_cast<uint32_t>(s_ndf[0]), ndf.data(), {},
               false);
  b.sigma_.build(static_cast<uint32_t>(s_sigma[1]), static_cast<uint32_t>(s_sigma[0]), sigma.data(),
                 {}, false);
  b.vndf_.build(static_cast<uint32_t>(s_vndf[3]), static_cast<uint32_t>(s_vndf[2]), vndf.data(),
                {b.phi_i_, b.theta_i_}, true);
  b.rgb_.build(static_cast<uint32_t>(s_rgb[4]), static_cast<uint32_t>(s_rgb[3]), rgb.data(),
               {b.phi_i_, b.theta_i_, channels}, false);
  return b;
}

bool RglBsdf::locate(const LocalDir& L, const LocalDir& V, float* sx, float* sy, float* scale,
                     float params[2]) const {
  // The reader's wi is toward the viewer, wo toward the light.
  const float ix = static_cast<float>(V.u), iy = static_cast<float>(V.w),
              iz = static_cast<float>(V.n);
  const float ox = static_cast<float>(L.u), oy = static_cast<float>(L.w),
              oz = static_cast<float>(L.n);
  if (iz <= 0 || oz <= 0) return false;
  float mx = ix + ox, my = iy + oy, mz = iz + oz;
  const float inv = 1.f / std::sqrt(mx * mx + my * my + mz * mz);
  mx *= inv, my *= inv, mz *= inv;
  const float theta_i = elevation(ix, iy, iz), phi_i = std::atan2(iy, ix);
  const float theta_m = elevation(mx, my, mz), phi_m = std::atan2(my, mx);
  const float ui_x = theta2u(theta_i), ui_y = phi2u(phi_i);
  float um_x = theta2u(theta_m), um_y = phi2u(isotropic_ ? phi_m - phi_i : phi_m);
  um_y -= std::floor(um_y);
  params[0] = phi_i, params[1] = theta_i;
  *sx = um_x, *sy = um_y;
  vndf_.invert(sx, sy, params);
  *scale = ndf_.eval(um_x, um_y, nullptr) / (4 * sigma_.eval(ui_x, ui_y, nullptr));
  return true;
}

std::vector<float> RglBsdf::eval_spectrum(const LocalDir& L, const LocalDir& V) const {
  std::vector<float> f(wavelengths_.size(), 0.f);
  float sx, sy, scale, params[2];
  if (wavelengths_.empty() || !locate(L, V, &sx, &sy, &scale, params)) return f;
  for (size_t k = 0; k < f.size(); ++k) {
    const float p[3] = {params[0], params[1], wavelengths_[k]};
    f[k] = rgb_.eval(sx, sy, p) * scale;
  }
  return f;
}

std::array<float, 3> RglBsdf::eval(const LocalDir& L, const LocalDir& V) const {
  std::array<float, 3> f{0, 0, 0};
  if (spectral()) {
    const std::vector<float> s = eval_spectrum(L, V);
    for (size_t k = 0; k < s.size(); ++k)
      for (int c = 0; c < 3; ++c) f[c] += rgb_weights_[k][c] * s[k];
    for (float& v : f) v = std::max(0.f, v);
    return f;
  }
  float sx, sy, scale, params[2];
  if (!locate(L, V, &sx, &sy, &scale, params)) return f;
  for (int c = 0; c < 3; ++c) {
    const float p[3] = {params[0], params[1], static_cast<float>(c)};
    f[c] = std::max(0.f, rgb_.eval(sx, sy, p));
  }
  for (float& v : f) v *= scale;
  return f;
}

std::vector<std::array<float, 3>> spectrum_rgb_weights(const std::vector<float>& nm) {
  // One lobe of the fit: a Gaussian of different widths below and above its peak.
  auto lobe = [](double l, double mu, double below, double above) {
    const double t = (l - mu) / (l < mu ? below : above);
    return std::exp(-0.5 * t * t);
  };
  constexpr double kXyzToRgb[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                      {-0.9692660, 1.8760108, 0.0415560},
                                      {0.0556434, -0.2040259, 1.0572252}};
  std::vector<std::array<double, 3>> w(nm.size(), {0, 0, 0});
  double total[3] = {0, 0, 0};
  for (size_t k = 0; k < nm.size(); ++k) {
    const double l = nm[k];
    const double width =
        nm.size() == 1 ? 1.0 : 0.5 * (nm[std::min(k + 1, nm.size() - 1)] - nm[k > 0 ? k - 1 : 0]);
    const double xyz[3] = {1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
                               0.065 * lobe(l, 501.1, 20.4, 26.2),
                           0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
                           1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8)};
    for (int c = 0; c < 3; ++c) {
      w[k][c] =
          width * (kXyzToRgb[c][0] * xyz[0] + kXyzToRgb[c][1] * xyz[1] + kXyzToRgb[c][2] * xyz[2]);
      total[c] += w[k][c];
    }
  }
  constexpr double kVisible = 1e-3;  // of a channel's weight over the visible range (~100 nm)
  for (int c = 0; c < 3; ++c)
    if (!(total[c] > kVisible))
      throw Error("wavelengths: from " + std::to_string(nm.front()) + " to " +
                  std::to_string(nm.back()) +
                  " nm, too few in the visible range to give R, G and B");
  std::vector<std::array<float, 3>> out(nm.size());
  for (size_t k = 0; k < nm.size(); ++k)
    for (int c = 0; c < 3; ++c) out[k][c] = static_cast<float>(w[k][c] / total[c]);
  return out;
}

bool is_rgl_bsdf(const std::string& path) {
  return path.size() > 5 && (path.compare(path.size() - 5, 5, ".bsdf") == 0 ||
                             path.compare(path.size() - 5, 5, ".BSDF") == 0);
}

void evaluate_table(const RglBsdf& b, SampleTable* t) {
  for (auto& row : t->rows) {
    const auto f =
        b.eval(dir_from_angles(row.theta_i, row.phi_i), dir_from_angles(row.theta_o, row.phi_o));
    for (int c = 0; c < 3; ++c) row.value[c] = f[c];
  }
  t->values = SampleTable::Values::kRGB;
}

SampleTable measured_table(const RglBsdf& b) {
  SampleTable t;
  std::vector<double> azimuths;
  if (b.isotropic())
    azimuths = {0, 45, 90, 135};
  else
    for (float p : b.phi_i()) azimuths.push_back(p * 180 / M_PI);
  constexpr int kGrid = 24;  // half vectors per viewer direction: kGrid x kGrid
  constexpr double kMaxViewDeg = 80, kMaxLightDeg = 85;
  for (float th : b.theta_i()) {
    const double tv = th * 180 / M_PI;
    if (tv > kMaxViewDeg) continue;
    for (double pv : azimuths) {
      const LocalDir V = dir_from_angles(tv, pv);
      for (int j = 0; j < kGrid; ++j)
        for (int i = 0; i < kGrid; ++i) {
          const double u = (i + 0.5) / kGrid, th_h = u * u * M_PI / 2,
                       ph_h = 2 * M_PI * (j + 0.5) / kGrid;
          const double hx = std::sin(th_h) * std::cos(ph_h), hy = std::sin(th_h) * std::sin(ph_h),
                       hz = std::cos(th_h);
          const double d = V.u * hx + V.w * hy + V.n * hz;
          const double lx = 2 * d * hx - V.u, ly = 2 * d * hy - V.w, lz = 2 * d * hz - V.n;
          if (!(lz > std::cos(kMaxLightDeg * M_PI / 180))) continue;
          SampleRow r;
          r.theta_i = std::acos(std::clamp(lz, -1.0, 1.0)) * 180 / M_PI;
          r.phi_i = std::atan2(ly, lx) * 180 / M_PI;
          r.theta_o = tv, r.phi_o = pv;
          t.rows.push_back(r);
        }
    }
  }
  evaluate_table(b, &t);
  return t;
}

}  // namespace aniso
