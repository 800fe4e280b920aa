#pragma once

// Reduction of a field book (survey/field_book.h) to observation sets: rounds recognised in
// each set-up, face-left/face-right pairs meaned to one direction, zenith angle and slope
// distance per target and round, the face differences (collimation, index error) per target
// and per set-up, checked against tolerances.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mmba/core/settings_table.h"
#include "mmba/survey/field_book.h"

namespace mmba::survey {

/// Tolerances of the face check and the a-priori σ of the reduced observations (`mmba survey
/// --set NAME=VALUE`).
struct FaceReductionOptions {
  /// A pair whose collimation c differs from its set-up's median c by more than this is named
  /// a blunder [mgon, > 0]. c of one pair scatters by σ_face/√2 (σ_face: one pointing).
  double collimation_tolerance_mgon = 3.0;
  /// Same for the index error i = (V_I + V_II − 400)/2 [mgon, > 0].
  double index_tolerance_mgon = 3.0;
  /// A pair whose two slope distances differ by more than this is named a blunder [mm, > 0].
  double face_distance_tolerance_mm = 5.0;
  /// σ of a direction meaned from two faces [cc, > 0] (1 cc = 0.1 mgon).
  double direction_sigma_cc = 3.5;
  /// σ of a zenith angle meaned from two faces [cc, > 0] ...
  double zenith_sigma_cc = 3.0;
  /// ... combined with the error of the instrument and reflector heights over the distance D:
  /// σ_z² = zenith_sigma² + (height_sigma / D)² [mm, >= 0] (heights measured with a tape).
  double height_sigma_mm = 1.0;
  /// σ of a slope distance: a + b·D, a [mm, > 0] ...
  double distance_sigma_mm = 1.0;
  /// ... b [mm/km = ppm, >= 0].
  double distance_sigma_ppm = 1.5;
  bool Check(std::string* error) const;
};

/// The settings table of FaceReductionOptions.
const SettingsTable<FaceReductionOptions>& FaceReductionSettingsTable();

/// One target in one round of a set-up: its faces and, with both, the face differences.
struct FacePair {
  size_t setup = 0;  ///< index into FieldBook::setups
  int round = 0;     ///< 1-based round within the set-up
  std::string station;
  std::string target;
  int line_face1 = 0;  ///< input line of the face-I pointing (0: none)
  int line_face2 = 0;  ///< input line of the face-II pointing (0: none)
  bool has_collimation = false;
  double collimation_mgon = 0.0;  ///< c = (Hz_I − Hz_II ± 200 gon)/2
  bool has_index = false;
  double index_mgon = 0.0;  ///< i = (V_I + V_II − 400 gon)/2
  bool has_distance_difference = false;
  double distance_difference_mm = 0.0;  ///< D_I − D_II
  std::string blunder;  ///< empty, or what exceeds its tolerance and by how much
};

/// Face differences of one set-up: mean and standard deviation over its pairs.
struct SetupFaceSummary {
  size_t setup = 0;
  std::string station;
  int line = 0;
  int rounds = 0;
  int pairs = 0;        ///< targets seen in both faces
  int single_face = 0;  ///< targets seen in one face only
  int collimation_count = 0;
  double collimation_mean_mgon = 0.0;
  double collimation_median_mgon = 0.0;
  double collimation_std_mgon = 0.0;
  int index_count = 0;
  double index_mean_mgon = 0.0;
  double index_median_mgon = 0.0;
  double index_std_mgon = 0.0;
  int blunders = 0;
};

/// A reduced observation of one target in one round. Angles clockwise in radians.
struct ReducedObservation {
  std::string target;
  int line = 0;  ///< line of the first pointing
  int faces = 0;  ///< 1 or 2
  bool has_direction = false;
  double direction_rad = 0.0;  ///< face-I circle reading corrected by c, [0, 2π)
  bool has_zenith = false;
  double zenith_rad = 0.0;
  bool has_slope = false;
  double slope_m = 0.0;
  /// Horizontal distance (WI 32) meaned over the faces, used only where no slope distance was
  /// recorded.
  bool has_horizontal = false;
  double horizontal_m = 0.0;
  double reflector_height_m = 0.0;
};

/// The observations of one round of one set-up: one direction set (one orientation unknown).
struct ReducedSet {
  size_t setup = 0;
  int round = 0;
  std::string station;
  int line = 0;
  double instrument_height_m = 0.0;
  std::vector<ReducedObservation> observations;
};

struct FaceReduction {
  std::vector<ReducedSet> sets;
  std::vector<FacePair> pairs;
  std::vector<SetupFaceSummary> setups;
  size_t raw_observations = 0;
  /// Blunders named, "file:line station -> target: ...", one per pair.
  std::vector<std::string> blunders;
  /// Overall standard deviation of c and i about their set-up medians [mgon].
  double collimation_std_mgon = 0.0;
  double index_std_mgon = 0.0;
};

/// Reduces `book`: within each set-up a round ends when a face-I pointing follows face-II
/// ones or a (target, face) repeats; in a round the faces of a target are paired (face II by
/// V > 200 gon) and meaned: direction = Hz_I − c, zenith = V_I − i, distance = the mean.
/// A target seen in one face keeps that face (face II turned by 200 gon, zenith 400 − V).
/// Every round stays its own set. The face differences are checked against the options'
/// tolerances about the set-up's medians, and pairs beyond them are named.
FaceReduction ReduceFaces(const FieldBook& book, const FaceReductionOptions& options);

/// A text block for the terminal: per set-up the rounds, pairs, mean ± σ of c and i, and
/// the blunders.
std::string FaceReductionSummary(const FaceReduction& reduction);

/// The reduction for adjusted.json: "face_reduction": {raw_observations, sets, pairs,
/// collimation_std_mgon, index_std_mgon, setups[...], blunders[...]}.
nlohmann::json FaceReductionToJson(const FaceReduction& reduction);

/// face_differences.csv: one row per target and round: setup, station, round, target,
/// line_face1, line_face2, collimation_mgon, index_mgon, distance_difference_mm, blunder.
std::string FaceDifferencesCsv(const FaceReduction& reduction);

}  // namespace mmba::survey
