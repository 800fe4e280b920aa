#pragma once

// The field book: what a total-station raw file holds, whatever its format (Leica GSI, and
// room for Sokkia SDR33, Trimble M5, ...): station set-ups in the order they were recorded,
// each with its raw target observations in recording order (so both faces and repeated
// rounds can be recognised by the reduction), and coordinates of points stored in the file.
// One reader unit per format fills it (io_survey/gsi.h); one reduction unit turns it into
// observation sets (survey/face_reduction.h).

#include <string>
#include <vector>

#include <Eigen/Core>

namespace mmba::survey {

/// One pointing of the telescope at a target as recorded, in the instrument's own circle
/// readings (not reduced). Angles in radians, lengths in metres.
struct RawObservation {
  std::string target;  ///< point id (GSI WI 11)
  int line = 0;        ///< input line
  bool has_hz = false;
  double hz_rad = 0.0;  ///< horizontal circle reading, clockwise, [0, 2π)
  bool has_v = false;
  double v_rad = 0.0;  ///< vertical circle reading as a zenith angle, (0, 2π); > π is face II
  bool has_slope = false;
  double slope_m = 0.0;  ///< slope distance (the instrument's ppm and prism constant applied)
  bool has_horizontal = false;
  double horizontal_m = 0.0;  ///< horizontal distance as the instrument computed it
  bool has_height_diff = false;
  double height_diff_m = 0.0;  ///< height difference as the instrument computed it
  bool has_reflector_height = false;
  double reflector_height_m = 0.0;  ///< reflector (target) height above the point
  bool has_ppm_prism = false;
  double ppm = 0.0;              ///< atmospheric correction the instrument applied [ppm]
  double prism_constant_mm = 0.0;  ///< prism constant the instrument applied [mm]
  std::string code;  ///< remark / point code (GSI WI 71), information only
};

/// One set-up of the instrument over a station: its height and the observations recorded
/// until the next set-up.
struct Setup {
  std::string station;
  int line = 0;
  bool has_instrument_height = false;
  double instrument_height_m = 0.0;
  std::vector<RawObservation> observations;
};

/// Coordinates of a point stored in a field file or a coordinate list. `en_h` = (east, north,
/// height) in metres.
struct KnownPoint {
  std::string id;
  Eigen::Vector3d en_h = Eigen::Vector3d::Zero();
  bool has_xy = false;
  bool has_z = false;
  std::string file;
  int line = 0;
};

/// A field file read: set-ups with their raw observations, and the coordinates it holds
/// (station coordinates of a set-up record, or coordinate records).
struct FieldBook {
  std::string source;  ///< file name, for messages
  std::string format;  ///< e.g. "GSI-16", "GSI-8", "GSI-8/16" (mixed)
  std::vector<Setup> setups;
  std::vector<KnownPoint> points;
  size_t RawObservationCount() const {
    size_t n = 0;
    for (const Setup& s : setups) n += s.observations.size();
    return n;
  }
};

}  // namespace mmba::survey
