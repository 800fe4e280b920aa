// LAS 1.4 writer. Byte layout from the ASPRS LAS Specification 1.4 R15: public header block
// (Table 3, 375 bytes), VLR header (Table 15, 54 bytes), OGC Coordinate System WKT record
// (section 2.5, record 2112), Extra Bytes record (Table 24, 192-byte descriptors), point data
// record formats 6 and 7 (Tables 13 and 14, 30 and 36 bytes). All values little-endian.

#include "mmba/io_cloud/las_writer.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <set>
#include <stdexcept>

#include "io_cloud/point_cloud_internal.h"
#include "mmba/core/atomic_file.h"
#include "mmba/core/version.h"

namespace mmba::io {
namespace {

constexpr uint16_t kHeaderSize = 375;
constexpr size_t kVlrHeaderSize = 54;
constexpr size_t kDescriptorSize = 192;

// Stores `v` little-endian at `pos` of `buf`.
template <typename T>
void Put(std::string* buf, size_t pos, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  if (!internal::HostIsLittleEndian()) std::reverse(bytes, bytes + sizeof(T));
  buf->replace(pos, sizeof(T), bytes, sizeof(T));
}

// Copies `text` into a NUL-padded char[size] field at `pos`.
void PutText(std::string* buf, size_t pos, const std::string& text, size_t size) {
  buf->replace(pos, std::min(text.size(), size), text.substr(0, size));
}

// A VLR: the 54-byte header (reserved, user id, record id, length after header,
// description) and its payload.
std::string Vlr(const std::string& user_id, uint16_t record_id, const std::string& description,
                const std::string& payload) {
  if (payload.size() > 65535) {
    throw std::invalid_argument("WriteLas: the " + description + " record holds " + std::to_string(payload.size()) +
                                " bytes; a VLR holds at most 65535");
  }
  std::string vlr(kVlrHeaderSize, '\0');
  PutText(&vlr, 2, user_id, 16);
  Put<uint16_t>(&vlr, 18, record_id);
  Put<uint16_t>(&vlr, 20, static_cast<uint16_t>(payload.size()));
  PutText(&vlr, 22, description, 32);
  return vlr + payload;
}

// One Extra Bytes descriptor (Table 24): data type 9 (float) or 10 (double), min and max
// given (options bits 1 and 2), no scale or offset.
std::string Descriptor(const LasExtraField& field) {
  std::string d(kDescriptorSize, '\0');
  d[2] = static_cast<char>(field.is_double ? 10 : 9);
  PutText(&d, 4, field.name, 32);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : field.values) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  if (lo <= hi) {  // some finite value: min and max given (floating types store them as double)
    d[3] = static_cast<char>(0x06);
    Put<double>(&d, 64, lo);
    Put<double>(&d, 88, hi);
  }
  PutText(&d, 160, field.description, 32);
  return d;
}

void CheckLayout(const PointCloud& like, const std::vector<LasExtraField>& extra, bool with_values) {
  const size_t n = like.size();
  auto check = [&](size_t size, const std::string& what) {
    if (size != 0 && size != n) {
      throw std::invalid_argument("WriteLas: " + what + " has " + std::to_string(size) + " entries for " +
                                  std::to_string(n) + " points");
    }
  };
  check(like.intensity.size(), "intensity");
  check(like.colors.size(), "colors");
  check(like.time.size(), "time");
  std::set<std::string> names;
  for (const LasExtraField& f : extra) {
    if (f.name.empty() || f.name.size() > 32 || !names.insert(f.name).second) {
      throw std::invalid_argument("WriteLas: extra field name '" + f.name +
                                  "'; expected 1 to 32 characters, each name once");
    }
    if (with_values && f.values.size() != n) {
      throw std::invalid_argument("WriteLas: extra field " + f.name + " has " + std::to_string(f.values.size()) +
                                  " values for " + std::to_string(n) + " points");
    }
  }
}

// The intensity scale: the option, or 65535 for reflectances within 0..1, else 1.
double ChooseIntensityScale(const LasWriteOptions& options, const PointCloud& cloud) {
  if (options.intensity_scale > 0.0) return options.intensity_scale;
  for (float v : cloud.intensity) {
    if (!(v >= 0.0f && v <= 1.0f)) return 1.0;
  }
  return cloud.has_intensity() ? 65535.0 : 1.0;
}

}  // namespace

bool LasWriteOptions::Check(std::string* error) const {
  if (!(scale_m > 0.0) || !std::isfinite(scale_m)) {
    *error = "scale_m = " + std::to_string(scale_m) + "; expected a finite number > 0";
    return false;
  }
  if (offset_m && !offset_m->allFinite()) {
    *error = "offset_m: expected finite numbers";
    return false;
  }
  if (!(intensity_scale >= 0.0) || !std::isfinite(intensity_scale)) {
    *error = "intensity_scale = " + std::to_string(intensity_scale) + "; expected a finite number >= 0";
    return false;
  }
  return true;
}

LasStreamWriter::LasStreamWriter(std::ostream* out, const PointCloud& like, const LasWriteOptions& options,
                                 const std::vector<LasExtraField>& extra_layout)
    : out_(out),
      options_(options),
      has_colors_(like.has_colors()),
      has_time_(like.has_time()),
      has_intensity_(like.has_intensity()),
      layout_(extra_layout) {
  std::string error;
  if (!options_.Check(&error)) throw std::invalid_argument("LasWriteOptions: " + error);
  CheckLayout(like, layout_, false);
  intensity_scale_ = ChooseIntensityScale(options_, like);
  if (options_.offset_m) {
    offset_ = *options_.offset_m;
    offset_set_ = true;
  }
  min_.setConstant(std::numeric_limits<double>::infinity());
  max_.setConstant(-std::numeric_limits<double>::infinity());
  record_length_ = has_colors_ ? 36 : 30;
  std::string vlrs;
  if (!options_.crs_wkt.empty()) {
    // The WKT is stored NUL-terminated (R15 section 2.5: "null-terminated string").
    vlrs += Vlr("LASF_Projection", 2112, "OGC Coordinate System WKT", options_.crs_wkt + std::string(1, '\0'));
    ++num_vlrs_;
  }
  if (!layout_.empty()) {
    std::string descriptors;
    for (const LasExtraField& f : layout_) {
      descriptors += Descriptor(f);
      record_length_ += f.is_double ? 8 : 4;
    }
    vlrs += Vlr("LASF_Spec", 4, "Extra Bytes", descriptors);
    ++num_vlrs_;
  }
  offset_to_points_ = static_cast<uint32_t>(kHeaderSize + vlrs.size());
  WriteHeader();
  out_->write(vlrs.data(), static_cast<std::streamsize>(vlrs.size()));
}

void LasStreamWriter::WriteHeader() {
  std::string h(kHeaderSize, '\0');
  h.replace(0, 4, "LASF");
  // Bit 0 GPS time type, bit 3 synthetic return numbers (every point is return 1 of 1),
  // bit 4 WKT (formats 6–10 must use WKT, R15 section 3).
  const uint16_t encoding = (options_.adjusted_standard_gps_time ? 1 : 0) | (1 << 3) | (1 << 4);
  Put<uint16_t>(&h, 6, encoding);
  h[24] = 1;
  h[25] = 4;
  PutText(&h, 26, "OTHER", 32);
  PutText(&h, 58, std::string("mmba ") + Version() + " " + GitCommit(), 32);
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  Put<uint16_t>(&h, 90, static_cast<uint16_t>(utc.tm_yday + 1));
  Put<uint16_t>(&h, 92, static_cast<uint16_t>(utc.tm_year + 1900));
  Put<uint16_t>(&h, 94, kHeaderSize);
  Put<uint32_t>(&h, 96, offset_to_points_);
  Put<uint32_t>(&h, 100, num_vlrs_);
  h[104] = static_cast<char>(has_colors_ ? 7 : 6);
  Put<uint16_t>(&h, 105, record_length_);
  // Legacy counts (bytes 107–130) stay 0: required for formats >= 6.
  for (int k = 0; k < 3; ++k) {
    Put<double>(&h, 131 + 8 * k, options_.scale_m);
    Put<double>(&h, 155 + 8 * k, offset_[k]);
    const bool any = num_points_ > 0;
    Put<double>(&h, 179 + 16 * k, any ? max_[k] : 0.0);
    Put<double>(&h, 187 + 16 * k, any ? min_[k] : 0.0);
  }
  // 227 waveform start, 235 first EVLR, 243 EVLR count: 0 (none).
  Put<uint64_t>(&h, 247, num_points_);
  Put<uint64_t>(&h, 255, num_points_);  // every point is a first return
  out_->write(h.data(), kHeaderSize);
}

void LasStreamWriter::Append(const PointCloud& chunk, const std::vector<LasExtraField>& extra) {
  if (chunk.has_colors() != has_colors_ || chunk.has_time() != has_time_ ||
      chunk.has_intensity() != has_intensity_ || extra.size() != layout_.size()) {
    throw std::invalid_argument("LasStreamWriter::Append: the chunk's attributes or extra fields differ from the layout");
  }
  CheckLayout(chunk, extra, true);
  if (!offset_set_ && !chunk.empty()) {
    Eigen::Vector3d lo = chunk.points[0];
    for (const Eigen::Vector3d& p : chunk.points) lo = lo.cwiseMin(p);
    offset_ = lo.array().floor().matrix();
    offset_set_ = true;
  }
  std::string rec(record_length_, '\0');
  for (size_t i = 0; i < chunk.size(); ++i) {
    std::fill(rec.begin(), rec.end(), '\0');
    const Eigen::Vector3d& p = chunk.points[i];
    for (int k = 0; k < 3; ++k) {
      const double q = std::round((p[k] - offset_[k]) / options_.scale_m);
      if (!(std::abs(q) <= 2147483647.0)) {
        throw std::invalid_argument("WriteLas: point " + std::to_string(num_points_ + i) + " coordinate " +
                                    std::to_string(p[k]) + " is not finite or beyond the int32 range of scale " +
                                    std::to_string(options_.scale_m) + " around offset " + std::to_string(offset_[k]));
      }
      Put<int32_t>(&rec, 4 * k, static_cast<int32_t>(q));
      min_[k] = std::min(min_[k], q * options_.scale_m + offset_[k]);
      max_[k] = std::max(max_[k], q * options_.scale_m + offset_[k]);
    }
    if (has_intensity_) {
      const double v = std::round(static_cast<double>(chunk.intensity[i]) * intensity_scale_);
      Put<uint16_t>(&rec, 12, static_cast<uint16_t>(std::clamp(std::isfinite(v) ? v : 0.0, 0.0, 65535.0)));
    }
    rec[14] = static_cast<char>(0x11);  // return number 1 (bits 0–3), number of returns 1 (bits 4–7)
    if (has_time_) Put<double>(&rec, 22, chunk.time[i]);
    if (has_colors_) {
      for (int k = 0; k < 3; ++k) Put<uint16_t>(&rec, 30 + 2 * k, static_cast<uint16_t>(chunk.colors[i][k] * 257));
    }
    size_t pos = has_colors_ ? 36 : 30;
    for (const LasExtraField& f : extra) {
      if (f.is_double) {
        Put<double>(&rec, pos, f.values[i]);
        pos += 8;
      } else {
        Put<float>(&rec, pos, static_cast<float>(f.values[i]));
        pos += 4;
      }
    }
    out_->write(rec.data(), record_length_);
  }
  num_points_ += chunk.size();
}

void LasStreamWriter::Finish() {
  const std::streampos end = out_->tellp();
  out_->seekp(0);
  WriteHeader();
  out_->seekp(end);
  if (!*out_) throw std::runtime_error("LasStreamWriter: the stream refused the header rewrite (not seekable?)");
}

void WriteLas(const PointCloud& cloud, const std::string& path, const LasWriteOptions& options,
              const std::vector<LasExtraField>& extra) {
  CheckLayout(cloud, extra, true);
  LasWriteOptions chosen = options;
  if (!chosen.offset_m && !cloud.empty()) {
    Eigen::Vector3d lo = cloud.points[0];
    for (const Eigen::Vector3d& p : cloud.points) lo = lo.cwiseMin(p);
    chosen.offset_m = lo.array().floor().matrix();
  }
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        LasStreamWriter writer(&out, cloud, chosen, extra);
        writer.Append(cloud, extra);
        writer.Finish();
      },
      /*binary=*/true);
}

}  // namespace mmba::io
