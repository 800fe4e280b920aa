#include "mmba/io/exif_gps.h"

#include <cmath>

#include <exiv2/exiv2.hpp>

#include "mmba/core/error.h"

namespace mmba::io {
namespace {

double RationalValue(const Exiv2::Value& value, long index, const std::string& path, const std::string& tag) {
  const Exiv2::Rational r = value.toRational(index);
  if (r.second == 0) {
    throw InputError::Message(path, "EXIF " + tag + ": found " + value.toString() + ", expected rationals with non-zero denominators");
  }
  return static_cast<double>(r.first) / r.second;
}

/// Degrees from the tag's degrees, minutes, seconds (fewer components: the rest are 0).
double Dms(const Exiv2::Exifdatum& datum, const std::string& path) {
  const std::string tag = datum.tagName();
  double degrees = 0, scale = 1;
  for (long k = 0; k < std::min<long>(3, datum.count()); ++k, scale *= 60) {
    degrees += RationalValue(datum.value(), k, path, tag) / scale;
  }
  return degrees;
}

/// +1 or -1 from a reference tag (N/E positive, S/W negative).
double Sign(const Exiv2::ExifData& exif, const char* key, char positive, char negative, const std::string& path) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  const std::string ref = it == exif.end() ? std::string(1, positive) : it->toString();
  if (ref.size() >= 1 && ref[0] == positive) return 1;
  if (ref.size() >= 1 && ref[0] == negative) return -1;
  throw InputError::Message(path, std::string("EXIF ") + key + ": found '" + ref + "', expected " + positive + " or " + negative);
}

}  // namespace

std::optional<ExifGps> ReadExifGps(const std::string& path) {
  Exiv2::LogMsg::setLevel(Exiv2::LogMsg::mute);
  Exiv2::ExifData exif;
  try {
    auto image = Exiv2::ImageFactory::open(path);
    image->readMetadata();
    exif = image->exifData();
  } catch (const Exiv2::AnyError& e) {
    throw InputError::Message(path, std::string("cannot read the image's metadata (exiv2: ") + e.what() + ")");
  }
  const auto lat = exif.findKey(Exiv2::ExifKey("Exif.GPSInfo.GPSLatitude"));
  const auto lon = exif.findKey(Exiv2::ExifKey("Exif.GPSInfo.GPSLongitude"));
  if (lat == exif.end() || lon == exif.end()) return std::nullopt;
  ExifGps gps;
  gps.latitude_deg = Sign(exif, "Exif.GPSInfo.GPSLatitudeRef", 'N', 'S', path) * Dms(*lat, path);
  gps.longitude_deg = Sign(exif, "Exif.GPSInfo.GPSLongitudeRef", 'E', 'W', path) * Dms(*lon, path);
  if (std::abs(gps.latitude_deg) > 90 || std::abs(gps.longitude_deg) > 180) {
    throw InputError::Message(path, "EXIF GPS position " + std::to_string(gps.latitude_deg) + ", " +
                                        std::to_string(gps.longitude_deg) + ": expected latitude in [-90, 90], longitude in [-180, 180] degrees");
  }
  const auto alt = exif.findKey(Exiv2::ExifKey("Exif.GPSInfo.GPSAltitude"));
  if (alt != exif.end() && alt->count() >= 1) {
    const auto ref = exif.findKey(Exiv2::ExifKey("Exif.GPSInfo.GPSAltitudeRef"));
    const bool below = ref != exif.end() && ref->count() >= 1 && ref->toLong(0) == 1;
    gps.altitude_m = (below ? -1 : 1) * RationalValue(alt->value(), 0, path, alt->tagName());
  }
  return gps;
}

}  // namespace mmba::io
