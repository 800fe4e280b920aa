// The GPS position a camera wrote into a photo's EXIF (EXIF 2.32, "GPS Attribute Information":
// GPSLatitude/GPSLongitude as degrees, minutes, seconds rationals with their N/S, E/W
// references; GPSAltitude with GPSAltitudeRef 0 above, 1 below sea level), read with exiv2.
//
// EXIF states the altitude above sea level (a height above the geoid, as the receiver's
// geoid model gives it); some drones write the ellipsoidal height in the same tag. The reader
// returns the number as written; what it is (and the geoid undulation to add) is the user's
// statement in the project (docs/project-yaml.md, gnss `photos`).
#pragma once

#include <optional>
#include <string>

namespace mmba::io {

struct ExifGps {
  double latitude_deg = 0;   ///< WGS84, north positive
  double longitude_deg = 0;  ///< east positive
  std::optional<double> altitude_m;  ///< GPSAltitude signed by GPSAltitudeRef; none when absent
};

/// The GPS position in `image_path`'s EXIF; std::nullopt when the image has no GPS latitude
/// and longitude. InputError naming the file and the tag for an image exiv2 cannot read, a
/// zero denominator, a reference other than N/S or E/W, or a latitude beyond 90° (longitude
/// beyond 180°).
std::optional<ExifGps> ReadExifGps(const std::string& image_path);

}  // namespace mmba::io
