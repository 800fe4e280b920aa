#include "mmba/registration/cloud/registration_settings.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <type_traits>
#include <variant>

namespace mmba::registration {
namespace {

using Options = CloudRegistrationOptions;
using Member = std::variant<double Options::*, int Options::*, bool Options::*>;

// A value v is accepted when lo <= v <= hi (lo < v when lo_open; v < hi when hi_open).
struct Entry {
  const char* name;
  Member member;
  double lo, hi;
  bool lo_open, hi_open;
  const char* description;
};

constexpr double kInf = std::numeric_limits<double>::infinity();

// The tunable settings of CloudRegistrationOptions, ranges as its comments state them. The
// radii in metres, the descriptor, gravity, the search window and the normal orientation
// have options of their own.
const std::vector<Entry>& Entries() {
  static const std::vector<Entry> entries = {
      {"normal_radius_spacing", &Options::normal_radius_spacing, 0, kInf, true, true,
       "R_n in point spacings when --normal-radius is not given"},
      {"support_radius_spacing", &Options::support_radius_spacing, 0, kInf, true, true,
       "R_s in point spacings when --support-radius is not given"},
      {"keypoint_threshold", &Options::keypoint_threshold, 0, 1.0 / 3.0, false, false,
       "F_t: smallest eigenvalue of the normals' covariance for a 3D Kanade-Tomasi keypoint (paper 0.1)"},
      {"keypoint_grid_spacing", &Options::keypoint_grid_spacing, 0, kInf, true, true,
       "keypoint grid cell in units of R_n: the strongest keypoint per cell"},
      {"min_keypoints", &Options::min_keypoints, 3, kInf, false, true,
       "below this F_t is lowered, then uniform grid points are used"},
      {"max_keypoints", &Options::max_keypoints, 3, kInf, false, true,
       "above this the keypoint grid is coarsened (>= min_keypoints)"},
      {"coarse_voxel_spacing", &Options::coarse_voxel_spacing, 1, kInf, false, true,
       "feature level: voxel of at least this many point spacings"},
      {"min_points_coarse", &Options::min_points_coarse, 10, kInf, false, true,
       "feature level keeps at least this many points of the smaller cloud"},
      {"max_points_features", &Options::max_points_features, 1000, kInf, false, true,
       "feature level: the voxel grows until the smaller cloud has at most this many points"},
      {"larger_cloud_factor", &Options::larger_cloud_factor, 1, kInf, false, true,
       "the larger cloud may keep this many times as many feature-level points"},
      {"max_points_icp", &Options::max_points_icp, 1000, kInf, false, true, "fine level points for ICP"},
      {"use_existing_normals", &Options::use_existing_normals, 0, 1, false, false,
       "use normals stored in the clouds"},
      {"remove_blunders", &Options::remove_blunders, 0, 1, false, false,
       "remove scattered isolated points first"},
      {"isolated_cell_spacing", &Options::isolated_cell_spacing, 0, kInf, true, true,
       "blunders: cell size in 90th-percentile neighbour distances"},
      {"isolated_min_neighbours", &Options::isolated_min_neighbours, 1, kInf, false, true,
       "blunders: fewer neighbours than this in the 27 cells = isolated"},
      {"isolated_min_fraction", &Options::isolated_min_fraction, 0, 1, false, false,
       "blunders: removed only when at least this fraction of the cloud"},
      {"sac_ia_iterations", &Options::sac_ia_iterations, 1, kInf, false, true, "SAC-IA samples scored"},
      {"sac_ia_draws_per_iteration", &Options::sac_ia_draws_per_iteration, 1, kInf, false, true,
       "SAC-IA draws at most this many samples per scored one"},
      {"sac_ia_randomness", &Options::sac_ia_randomness, 1, kInf, false, true,
       "SAC-IA picks among this many nearest features"},
      {"sac_ia_confidence", &Options::sac_ia_confidence, 0, 1, true, false,
       "SAC-IA stops once a correct sample was drawn with this probability (1 = never early)"},
      {"sac_ia_alternative_ratio", &Options::sac_ia_alternative_ratio, 0, 1, true, false,
       "SAC-IA keeps sampling for poses with this fraction of the best pose's matches"},
      {"num_hypotheses", &Options::num_hypotheses, 1, kInf, false, true, "hypotheses kept for ICP and verification"},
      {"use_max_clique", &Options::use_max_clique, 0, 1, false, false,
       "add the maximum-consistent-clique hypotheses"},
      {"num_cliques", &Options::num_cliques, 1, kInf, false, true, "cliques per descriptor"},
      {"consistency_spacing", &Options::consistency_spacing, 0, kInf, true, true,
       "clique: pairwise-length tolerance in point spacings"},
      {"max_correspondences", &Options::max_correspondences, 3, kInf, false, true,
       "correspondences fed to the clique search"},
      {"icp_iterations", &Options::icp_iterations, 1, kInf, false, true, "ICP iterations per level"},
      {"icp_distance_spacing", &Options::icp_distance_spacing, 0, kInf, true, true,
       "ICP final correspondence distance in point spacings"},
      {"icp_noise_sigmas", &Options::icp_noise_sigmas, 0, kInf, false, true,
       "fine ICP again with this many robust residual scales when larger (0 = off)"},
      {"icp_plane_to_plane", &Options::icp_plane_to_plane, 0, 1, false, false,
       "fine ICP: plane-to-plane residuals from both clouds' normals (Generalized-ICP)"},
      {"icp_plane_distance_spacing", &Options::icp_plane_distance_spacing, 0, kInf, true, true,
       "plane-to-plane fine ICP: final correspondence distance in point spacings"},
      {"inlier_distance_spacing", &Options::inlier_distance_spacing, 0, kInf, true, true,
       "inlier: distance to the target below this many point spacings"},
      {"inlier_sigma", &Options::inlier_sigma, 0, kInf, true, true,
       "fine verification: inlier below this many robust residual scales"},
      {"min_fitness", &Options::min_fitness, 0, 1, true, false, "fraction of the source that must be inliers"},
      {"min_normal_agreement", &Options::min_normal_agreement, 0, 1, true, false,
       "fraction of inliers whose normals agree within 30 deg"},
      {"max_ambiguity", &Options::max_ambiguity, 0, 1, false, false,
       "ambiguity test: finalists above this fraction of the best are compared (0 = all, 1 = off)"},
      {"min_coarse_agreement", &Options::min_coarse_agreement, 0, 1, false, false,
       "the chosen pose's coarse score at least this fraction of the best coarse finalist's (0 = off)"},
      {"min_significance", &Options::min_significance, 0, kInf, false, true,
       "the best must beat each competitor by this many standard errors"},
      {"num_period_shifts", &Options::num_period_shifts, 0, kInf, false, true,
       "repeated structures: displacement modes added to the ambiguity test (0 = off)"},
      {"symmetry_turns", &Options::symmetry_turns, 0, 1, false, false,
       "turned poses (90/180/270 deg) added to the ambiguity test"},
      {"local_search", &Options::local_search, 0, 1, false, false, "move an unresolved best along its slides"},
      {"symmetry_cone_deg", &Options::symmetry_cone_deg, 0, 180, false, false,
       "non-levelled turns: axes within this angle of each principal axis too"},
      {"symmetry_cone_step_deg", &Options::symmetry_cone_step_deg, 0, 180, true, false,
       "non-levelled turns: ring step, degrees"},
      {"intensity_test", &Options::intensity_test, 0, 1, false, false,
       "brightness rank correlation may settle a geometric tie"},
      {"resolution_t", &Options::resolution_t, 0, kInf, true, true,
       "a displacement is told apart when it scores worse by this many standard errors"},
      {"max_resolution_spacing", &Options::max_resolution_spacing, 0, kInf, true, true,
       "ok needs the pose resolved within this many fine point spacings"},
      {"probe_weak_motions", &Options::probe_weak_motions, 0, 1, false, false,
       "resolution test also along the fit's two least-constrained motions"},
      {"max_weak_motion_resolution_spacing", &Options::max_weak_motion_resolution_spacing, 0, kInf, true, true,
       "ok needs the weak motions told apart within this many fine point spacings"},
      {"check_fit_uncertainty", &Options::check_fit_uncertainty, 0, 1, false, false,
       "ok also needs the fit's covariance within the resolution bound"},
  };
  return entries;
}

std::string RangeText(const Entry& e) {
  if (std::holds_alternative<bool Options::*>(e.member)) return "true|false";
  std::ostringstream s;
  if (e.hi == kInf) {
    s << (e.lo_open ? "> " : ">= ") << e.lo;
  } else if (e.hi == 1.0 / 3.0) {
    s << e.lo << "..1/3";
  } else {
    s << (e.lo_open ? "(" : "[") << e.lo << ", " << e.hi << (e.hi_open ? ")" : "]");
  }
  return s.str();
}

}  // namespace

std::vector<RegistrationSetting> RegistrationSettings() {
  const Options defaults;
  std::vector<RegistrationSetting> out;
  for (const Entry& e : Entries()) {
    RegistrationSetting s;
    s.name = e.name;
    s.range = RangeText(e);
    s.description = e.description;
    std::ostringstream value;
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(defaults.*member)>;
          if constexpr (std::is_same_v<T, bool>) {
            s.kind = "true|false";
            value << (defaults.*member ? "true" : "false");
          } else {
            s.kind = std::is_same_v<T, int> ? "integer" : "number";
            value << defaults.*member;
          }
        },
        e.member);
    s.default_value = value.str();
    out.push_back(s);
  }
  return out;
}

bool SetRegistrationSetting(const std::string& name, const std::string& value, CloudRegistrationOptions* options,
                            std::string* problem) {
  const Entry* entry = nullptr;
  for (const Entry& e : Entries()) {
    if (name == e.name) entry = &e;
  }
  if (entry == nullptr) {
    *problem = "unknown setting '" + name + "' (mmba register-cloud --help lists them)";
    return false;
  }
  if (std::holds_alternative<bool Options::*>(entry->member)) {
    if (value != "true" && value != "false" && value != "1" && value != "0") {
      *problem = name + ": found '" + value + "', expected true or false";
      return false;
    }
    options->*std::get<bool Options::*>(entry->member) = value == "true" || value == "1";
    return true;
  }
  const bool integer = std::holds_alternative<int Options::*>(entry->member);
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  const bool number = !value.empty() && end == value.c_str() + value.size() && std::isfinite(v);
  const bool whole = number && (!integer || (v == std::floor(v) && std::abs(v) < 1e9));
  const bool in_range = number && (entry->lo_open ? v > entry->lo : v >= entry->lo) &&
                        (entry->hi_open ? v < entry->hi : v <= entry->hi);
  if (!whole || !in_range) {
    *problem = name + ": found '" + value + "', expected " + (integer ? "an integer " : "a number ") +
               RangeText(*entry);
    return false;
  }
  if (integer) {
    options->*std::get<int Options::*>(entry->member) = static_cast<int>(v);
  } else {
    options->*std::get<double Options::*>(entry->member) = v;
  }
  return true;
}

bool ApplyRegistrationSettings(const std::vector<std::string>& settings,
                               CloudRegistrationOptions* options, std::string* problem) {
  for (const std::string& setting : settings) {
    const size_t eq = setting.find('=');
    if (eq == std::string::npos) {
      *problem = "found '" + setting + "', expected NAME=VALUE";
      return false;
    }
    if (!SetRegistrationSetting(setting.substr(0, eq), setting.substr(eq + 1), options, problem)) {
      return false;
    }
  }
  return true;
}

}  // namespace mmba::registration
