#include "mmba/survey/face_reduction.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "survey/output_units_internal.h"

namespace mmba::survey {
namespace {

using internal::Fixed;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToMgon = 200.0e3 / kPi;

/// `a` wrapped to (−π, π].
double WrapPi(double a) {
  a = std::fmod(a, 2 * kPi);
  if (a <= -kPi) a += 2 * kPi;
  if (a > kPi) a -= 2 * kPi;
  return a;
}

double Wrap2Pi(double a) {
  a = std::fmod(a, 2 * kPi);
  return a < 0 ? a + 2 * kPi : a;
}

bool FaceTwo(const RawObservation& o) { return o.has_v && o.v_rad > kPi; }

/// Splits a set-up's pointings into rounds: a round ends when a face-I pointing follows
/// face-II ones, or when a (target, face) is pointed at again. Returns the round (1-based)
/// of each pointing.
std::vector<int> Rounds(const Setup& setup) {
  std::vector<int> round(setup.observations.size(), 1);
  int current = 1;
  bool seen_face2 = false;
  std::map<std::pair<std::string, bool>, int> seen;
  for (size_t k = 0; k < setup.observations.size(); ++k) {
    const RawObservation& o = setup.observations[k];
    const bool face2 = FaceTwo(o);
    if ((!face2 && seen_face2) || seen.count({o.target, face2})) {
      ++current;
      seen.clear();
      seen_face2 = false;
    }
    seen[{o.target, face2}] = 1;
    seen_face2 = seen_face2 || face2;
    round[k] = current;
  }
  return round;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// One target of one round: its face-I and face-II pointings (null when absent).
struct TargetFaces {
  const RawObservation* face1 = nullptr;
  const RawObservation* face2 = nullptr;
};

/// Means the two faces of a target (or turns a single face II to face I).
ReducedObservation Reduce(const TargetFaces& t, FacePair* pair) {
  ReducedObservation r;
  const RawObservation* first = t.face1 ? t.face1 : t.face2;
  r.target = first->target;
  r.line = std::min(t.face1 ? t.face1->line : first->line, t.face2 ? t.face2->line : first->line);
  r.faces = (t.face1 && t.face2) ? 2 : 1;
  r.reflector_height_m = first->reflector_height_m;
  if (t.face1 && t.face2) {
    if (t.face1->has_hz && t.face2->has_hz) {
      // c = (Hz_I − Hz_II ± 200 gon)/2; direction = Hz_I − c.
      const double c = 0.5 * WrapPi(t.face1->hz_rad - t.face2->hz_rad + kPi);
      r.direction_rad = Wrap2Pi(t.face1->hz_rad - c);
      r.has_direction = true;
      pair->has_collimation = true;
      pair->collimation_mgon = c * kRadToMgon;
    }
    if (t.face1->has_v && t.face2->has_v) {
      // i = (V_I + V_II − 400 gon)/2; zenith = V_I − i.
      const double i = 0.5 * (t.face1->v_rad + t.face2->v_rad - 2 * kPi);
      r.zenith_rad = t.face1->v_rad - i;
      r.has_zenith = true;
      pair->has_index = true;
      pair->index_mgon = i * kRadToMgon;
    }
    if (t.face1->has_slope && t.face2->has_slope) {
      r.slope_m = 0.5 * (t.face1->slope_m + t.face2->slope_m);
      r.has_slope = true;
      pair->has_distance_difference = true;
      pair->distance_difference_mm = (t.face1->slope_m - t.face2->slope_m) * 1e3;
    }
  }
  // What one face alone gives (also where the other face lacks a value).
  const RawObservation* one = t.face1 ? t.face1 : t.face2;
  const bool turned = one == t.face2;
  if (!r.has_direction && one->has_hz) {
    r.direction_rad = Wrap2Pi(one->hz_rad + (turned ? kPi : 0.0));
    r.has_direction = true;
  }
  if (!r.has_zenith && one->has_v) {
    r.zenith_rad = turned ? 2 * kPi - one->v_rad : one->v_rad;
    r.has_zenith = true;
  }
  if (!r.has_slope) {
    for (const RawObservation* o : {t.face1, t.face2}) {
      if (o && o->has_slope && !r.has_slope) {
        r.slope_m = o->slope_m;
        r.has_slope = true;
      }
    }
  }
  if (!r.has_slope) {  // a job that records horizontal distances only
    int n = 0;
    for (const RawObservation* o : {t.face1, t.face2}) {
      if (o && o->has_horizontal) r.horizontal_m += o->horizontal_m, ++n;
    }
    r.has_horizontal = n > 0;
    if (n > 0) r.horizontal_m /= n;
  }
  return r;
}

/// The reduced set of one round and its pairs (targets in order of first pointing).
ReducedSet ReduceRound(const FieldBook& book, size_t s, int round, const std::vector<int>& rounds,
                       std::vector<FacePair>* pairs) {
  const Setup& setup = book.setups[s];
  ReducedSet set;
  set.setup = s;
  set.round = round;
  set.station = setup.station;
  set.instrument_height_m = setup.instrument_height_m;
  std::vector<std::string> order;
  std::map<std::string, TargetFaces> faces;
  for (size_t k = 0; k < setup.observations.size(); ++k) {
    if (rounds[k] != round) continue;
    const RawObservation& o = setup.observations[k];
    if (set.line == 0) set.line = o.line;
    if (!faces.count(o.target)) order.push_back(o.target);
    (FaceTwo(o) ? faces[o.target].face2 : faces[o.target].face1) = &o;
  }
  for (const std::string& target : order) {
    const TargetFaces& t = faces[target];
    FacePair pair;
    pair.setup = s;
    pair.round = round;
    pair.station = setup.station;
    pair.target = target;
    pair.line_face1 = t.face1 ? t.face1->line : 0;
    pair.line_face2 = t.face2 ? t.face2->line : 0;
    const ReducedObservation r = Reduce(t, &pair);
    if (t.face1 && t.face2 && t.face1->has_reflector_height && t.face2->has_reflector_height &&
        std::abs(t.face1->reflector_height_m - t.face2->reflector_height_m) > 5e-4) {
      pair.blunder = "reflector height differs between the faces";
    }
    if (target != setup.station) set.observations.push_back(r);
    pairs->push_back(pair);
  }
  return set;
}

/// Medians, means and σ of c and i of set-up `s`, and the pairs beyond the tolerances.
SetupFaceSummary CheckSetup(const FieldBook& book, size_t s, const FaceReductionOptions& options,
                            std::vector<FacePair>* pairs, std::vector<std::string>* blunders) {
  SetupFaceSummary sum;
  sum.setup = s;
  sum.station = book.setups[s].station;
  sum.line = book.setups[s].line;
  std::vector<double> c, i;
  for (const FacePair& p : *pairs) {
    if (p.setup != s) continue;
    sum.rounds = std::max(sum.rounds, p.round);
    (p.line_face1 && p.line_face2 ? sum.pairs : sum.single_face)++;
    if (p.has_collimation) c.push_back(p.collimation_mgon);
    if (p.has_index) i.push_back(p.index_mgon);
  }
  auto stats = [](const std::vector<double>& v, int* n, double* mean, double* median, double* sd) {
    *n = static_cast<int>(v.size());
    if (v.empty()) return;
    double sum_v = 0;
    for (double x : v) sum_v += x;
    *mean = sum_v / v.size();
    *median = Median(v);
    double ss = 0;
    for (double x : v) ss += (x - *mean) * (x - *mean);
    *sd = v.size() > 1 ? std::sqrt(ss / (v.size() - 1)) : 0.0;
  };
  stats(c, &sum.collimation_count, &sum.collimation_mean_mgon, &sum.collimation_median_mgon,
        &sum.collimation_std_mgon);
  stats(i, &sum.index_count, &sum.index_mean_mgon, &sum.index_median_mgon, &sum.index_std_mgon);
  for (FacePair& p : *pairs) {
    if (p.setup != s) continue;
    std::string what = p.blunder;
    auto add = [&](const std::string& text) { what += (what.empty() ? "" : "; ") + text; };
    const double dc = p.collimation_mgon - sum.collimation_median_mgon;
    const double di = p.index_mgon - sum.index_median_mgon;
    if (p.has_collimation && std::abs(dc) > options.collimation_tolerance_mgon) {
      add("collimation " + Fixed(p.collimation_mgon, 2) + " mgon is " + Fixed(dc, 2) +
          " mgon from the set-up's median (tolerance " + Fixed(options.collimation_tolerance_mgon, 2) + ")");
    }
    if (p.has_index && std::abs(di) > options.index_tolerance_mgon) {
      add("index error " + Fixed(p.index_mgon, 2) + " mgon is " + Fixed(di, 2) +
          " mgon from the set-up's median (tolerance " + Fixed(options.index_tolerance_mgon, 2) + ")");
    }
    if (p.has_distance_difference &&
        std::abs(p.distance_difference_mm) > options.face_distance_tolerance_mm) {
      add("face distances differ by " + Fixed(p.distance_difference_mm, 1) + " mm (tolerance " +
          Fixed(options.face_distance_tolerance_mm, 1) + ")");
    }
    p.blunder = what;
    if (!what.empty()) {
      ++sum.blunders;
      const std::string where =
          p.line_face1 && p.line_face2
              ? std::to_string(p.line_face1) + " (face II at line " + std::to_string(p.line_face2) + ")"
              : std::to_string(p.line_face1 ? p.line_face1 : p.line_face2);
      blunders->push_back(book.source + ":" + where + " " + p.station + " -> " + p.target + " round " + std::to_string(p.round) +
                          ": " + what);
    }
  }
  return sum;
}

}  // namespace

bool FaceReductionOptions::Check(std::string* error) const {
  return FaceReductionSettingsTable().Check(*this, error);
}

const SettingsTable<FaceReductionOptions>& FaceReductionSettingsTable() {
  using O = FaceReductionOptions;
  static const SettingsTable<O> table =
      SettingsTable<O>("mmba survey --help lists them")
          .Number("collimation_tolerance_mgon", &O::collimation_tolerance_mgon, SettingRange::Above(0),
                  "field files: a pair's collimation beyond this from its set-up's median is a blunder")
          .Number("index_tolerance_mgon", &O::index_tolerance_mgon, SettingRange::Above(0),
                  "field files: same for the vertical index error")
          .Number("face_distance_tolerance_mm", &O::face_distance_tolerance_mm, SettingRange::Above(0),
                  "field files: largest difference of a pair's two slope distances")
          .Number("direction_sigma_cc", &O::direction_sigma_cc, SettingRange::Above(0),
                  "field files: a-priori sigma of a direction meaned from two faces")
          .Number("zenith_sigma_cc", &O::zenith_sigma_cc, SettingRange::Above(0),
                  "field files: a-priori sigma of a zenith angle meaned from two faces")
          .Number("height_sigma_mm", &O::height_sigma_mm, SettingRange::AtLeast(0),
                  "field files: sigma of instrument and reflector heights, added to a zenith angle's as sigma/D")
          .Number("distance_sigma_mm", &O::distance_sigma_mm, SettingRange::Above(0),
                  "field files: a-priori sigma of a slope distance, constant part")
          .Number("distance_sigma_ppm", &O::distance_sigma_ppm, SettingRange::AtLeast(0),
                  "field files: a-priori sigma of a slope distance, part proportional to it");
  return table;
}

FaceReduction ReduceFaces(const FieldBook& book, const FaceReductionOptions& options) {
  FaceReduction out;
  out.raw_observations = book.RawObservationCount();
  for (size_t s = 0; s < book.setups.size(); ++s) {
    const std::vector<int> rounds = Rounds(book.setups[s]);
    const int n_rounds = rounds.empty() ? 0 : *std::max_element(rounds.begin(), rounds.end());
    for (int r = 1; r <= n_rounds; ++r) {
      ReducedSet set = ReduceRound(book, s, r, rounds, &out.pairs);
      if (!set.observations.empty()) out.sets.push_back(std::move(set));
    }
    out.setups.push_back(CheckSetup(book, s, options, &out.pairs, &out.blunders));
  }
  double sc = 0, si = 0;
  size_t nc = 0, ni = 0;
  for (const FacePair& p : out.pairs) {
    const SetupFaceSummary& sum = out.setups[p.setup];
    if (p.has_collimation) sc += std::pow(p.collimation_mgon - sum.collimation_median_mgon, 2), ++nc;
    if (p.has_index) si += std::pow(p.index_mgon - sum.index_median_mgon, 2), ++ni;
  }
  out.collimation_std_mgon = nc > 1 ? std::sqrt(sc / (nc - 1)) : 0.0;
  out.index_std_mgon = ni > 1 ? std::sqrt(si / (ni - 1)) : 0.0;
  return out;
}

}  // namespace mmba::survey
