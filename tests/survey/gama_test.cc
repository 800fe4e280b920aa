// Every gama-local network of data/gama that has GNU Gama's own result (.xml) is adjusted
// and compared with that result: coordinates within 0.1 mm, standard deviations within 1 %,
// a-posteriori σ0 within 1 %, the same degrees of freedom and defect, the same χ² verdict
// and the same observation flagged by data snooping (largest studentized residual).

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <set>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "io_survey/xml_tree.h"
#include "mmba/io_survey/gama_local.h"
#include "mmba/io/text_reader.h"
#include "mmba/survey/adjust.h"
#include "mmba/survey/result_json.h"
#include "mmba/survey/result_report.h"
#include "mmba/survey/survey_group.h"

namespace mmba::survey {
namespace {

using io::xml::Element;

const Element* Child(const Element& e, const std::string& name) {
  for (const auto& c : e.children) {
    if (c->name == name) return c.get();
  }
  return nullptr;
}

double Num(const Element& e) { return std::stod(e.text); }

struct GamaPoint {
  std::map<char, double> value;  // 'x','y','z' (lower case) -> value
  std::map<char, int> cov_row;   // -> row of the cov-mat (0-based)
};

struct GamaObservation {
  std::string kind, from, to;
  double qrr = 0.0, f = 0.0, std_residual = 0.0;
  bool has_std_residual = false;
};

struct GamaResult {
  std::map<std::string, GamaPoint> adjusted;
  std::vector<double> cov_diag;
  int dof = 0, defect = 0;
  double apriori = 0.0, aposteriori = 0.0;
  std::string used;
  bool passed = false;
  bool no_test = false;
  std::vector<GamaObservation> observations;
};

GamaResult ReadGamaResult(const std::string& path) {
  const std::unique_ptr<Element> root = io::xml::Parse(io::ReadWholeFile(path), path);
  GamaResult r;
  const Element* summary = Child(*root, "network-processing-summary");
  const Element* equations = Child(*summary, "project-equations");
  r.dof = static_cast<int>(Num(*Child(*equations, "degrees-of-freedom")));
  r.defect = static_cast<int>(Num(*Child(*equations, "defect")));
  const Element* sd = Child(*summary, "standard-deviation");
  r.apriori = Num(*Child(*sd, "apriori"));
  r.aposteriori = Num(*Child(*sd, "aposteriori"));
  r.used = Child(*sd, "used")->text;
  r.passed = Child(*sd, "passed") != nullptr;
  r.no_test = r.used.find("apriori") == 0 && Num(*Child(*sd, "lower")) == 0.0 &&
              Num(*Child(*sd, "upper")) == 0.0;
  const Element* coordinates = Child(*root, "coordinates");
  int row = 0;
  for (const auto& point : Child(*coordinates, "adjusted")->children) {
    GamaPoint p;
    for (const auto& c : point->children) {
      if (c->name == "id") continue;
      const char axis = static_cast<char>(std::tolower(c->name[0]));
      p.value[axis] = Num(*c);
      p.cov_row[axis] = row++;
    }
    r.adjusted[Child(*point, "id")->text] = p;
  }
  const Element* cov = Child(*coordinates, "cov-mat");
  const int dim = static_cast<int>(Num(*Child(*cov, "dim")));
  const int band = static_cast<int>(Num(*Child(*cov, "band")));
  std::vector<double> flt;
  for (const auto& c : cov->children) {
    if (c->name == "flt") flt.push_back(Num(*c));
  }
  size_t k = 0;
  for (int i = 0; i < dim; ++i) {
    const int count = std::min(band, dim - 1 - i) + 1;
    r.cov_diag.push_back(flt.at(k));
    k += count;
  }
  for (const auto& o : Child(*root, "observations")->children) {
    GamaObservation g;
    g.kind = o->name;
    g.from = Child(*o, "from") ? Child(*o, "from")->text : "";
    g.to = Child(*o, "to") ? Child(*o, "to")->text : "";
    g.qrr = Num(*Child(*o, "qrr"));
    g.f = Num(*Child(*o, "f"));
    if (const Element* s = Child(*o, "std-residual")) {
      g.std_residual = Num(*s);
      g.has_std_residual = true;
    }
    r.observations.push_back(g);
  }
  return r;
}

std::string DataPath(const std::string& name) {
  return std::string(MMBA_SOURCE_DIR) + "/data/gama/" + name;
}

/// How far one network's adjustment is from Gama's (for the table in the test's output).
struct Agreement {
  double max_coordinate_mm = 0.0;   ///< max |ours − Gama| over adjusted coordinates
  double max_sigma_ratio = 1.0;     ///< the σ ratio ours/Gama farthest from 1
  double sigma0 = 0.0, gama_sigma0 = 0.0;
  int dof = 0, gama_dof = 0;
  bool passed = false, gama_passed = false;
};

/// Adjusts `gkf` and compares it with Gama's result `xml`; observations from or to a point
/// of `ignore` (points Gama's run of another network did not have) are skipped.
void CompareWithGama(const std::string& gkf, const std::string& xml, Agreement* agreement,
                     const std::set<std::string>& ignore = {}) {
  SCOPED_TRACE(gkf);
  SurveyNetwork net = io::ReadGamaLocal(gkf);
  const GamaResult gama = ReadGamaResult(xml);
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged) << adj.reason;
  agreement->dof = adj.statistics.degrees_of_freedom;
  agreement->gama_dof = gama.dof;
  agreement->sigma0 = net.sigma0_apriori * adj.statistics.sigma0_ratio;
  agreement->gama_sigma0 = gama.aposteriori;
  agreement->passed = adj.statistics.chi2_passed;
  agreement->gama_passed = gama.passed;
  const stats::NetworkStatistics& st = adj.statistics;

  EXPECT_EQ(st.degrees_of_freedom, gama.dof);
  EXPECT_EQ(st.defect, gama.defect);
  const double aposteriori = net.sigma0_apriori * st.sigma0_ratio;
  if (gama.aposteriori > 1e-6) {
    EXPECT_NEAR(aposteriori, gama.aposteriori, 0.01 * gama.aposteriori);
  } else {
    EXPECT_NEAR(aposteriori, 0.0, 1e-6);
  }
  if (gama.no_test) {
    // Gama 1.13a did not test σ0 when sigma-act="apriori" (its XML says "no test" and
    // writes <passed/>); nothing to compare.
    GTEST_LOG_(INFO) << gkf << ": Gama ran no chi2 test; ours says "
                     << (st.chi2_passed ? "passed" : "failed");
  } else {
    EXPECT_EQ(st.chi2_passed, gama.passed);
  }
  const double scale_mm = 1000.0;
  for (const auto& [id, gp] : gama.adjusted) {
    const SurveyPoint* p = net.Find(id);
    ASSERT_NE(p, nullptr) << id;
    const Eigen::Vector2d xy = net.axes.XyFromEn(p->coords.head<2>());
    const Eigen::Matrix3d cov = PointCovariance(adj, net, *p);
    for (const auto& [axis, value] : gp.value) {
      const int k = axis == 'x' ? 0 : axis == 'y' ? 1 : 2;
      const double ours = k < 2 ? xy[k] : p->coords.z();
      EXPECT_NEAR(ours, value, 1e-4) << "point " << id << " " << axis;
      const double gama_sigma = std::sqrt(gama.cov_diag.at(gp.cov_row.at(axis)));
      const double our_sigma = std::sqrt(cov(k, k)) * scale_mm;
      agreement->max_coordinate_mm =
          std::max(agreement->max_coordinate_mm, std::abs(ours - value) * 1000.0);
      if (gama_sigma > 0 && std::abs(our_sigma / gama_sigma - 1) > std::abs(agreement->max_sigma_ratio - 1)) {
        agreement->max_sigma_ratio = our_sigma / gama_sigma;
      }
      EXPECT_NEAR(our_sigma, gama_sigma, 0.01 * gama_sigma + 1e-9) << "sigma " << id << " " << axis;
    }
  }
  // Observations in Gama's order: by cluster, then within the cluster.
  std::map<std::pair<size_t, size_t>, size_t> row_of;
  for (size_t r = 0; r < adj.rows.size(); ++r) {
    const Observation& o = net.clusters[adj.rows[r].cluster].observations[adj.rows[r].observation];
    if (ignore.count(o.from) || ignore.count(o.to) || ignore.count(o.fs)) continue;
    row_of[{adj.rows[r].cluster, adj.rows[r].observation}] = r;
  }
  ASSERT_EQ(row_of.size(), gama.observations.size());
  size_t i = 0;
  int gama_max = -1, our_max = -1;
  double gama_max_value = -1, our_max_value = -1;
  for (const auto& [key, r] : row_of) {
    const GamaObservation& g = gama.observations[i];
    const Observation& o = net.clusters[key.first].observations[key.second];
    EXPECT_EQ(o.from, g.from) << "observation " << i;
    const stats::RowStatistic& row = st.rows[r];
    // Gama's qrr is the residual weight coefficient (1 − q_bb)/w, w = (σ0_apr/σ)².
    const double w = std::pow(net.sigma0_apriori / (o.sigma * (survey::ObsKindIsAngle(o.kind)
                                                                  ? 2.0e6 / M_PI
                                                                  : 1000.0)),
                              2);
    EXPECT_NEAR(row.redundancy / w, g.qrr, 1.5e-3) << "qrr of observation " << i;
    EXPECT_NEAR(row.control, g.f, 0.02) << "f of observation " << i;
    if (g.has_std_residual) {
      EXPECT_NEAR(std::abs(row.studentized), g.std_residual, 0.01 * g.std_residual + 2e-3)
          << "std-residual of observation " << i << " " << g.kind << " " << g.from << "->"
          << g.to;
      if (g.f >= 0.1 && g.std_residual > gama_max_value) {
        gama_max_value = g.std_residual;
        gama_max = static_cast<int>(i);
      }
      if (row.control >= 0.1 && std::abs(row.studentized) > our_max_value) {
        our_max_value = std::abs(row.studentized);
        our_max = static_cast<int>(i);
      }
    }
    ++i;
  }
  if (gama_max >= 0) {
    EXPECT_EQ(our_max, gama_max) << "data snooping flags another observation";
    // The statistics module's own snooping choice is the same observation.
    int position = 0, max_position = -1;
    for (const auto& entry : row_of) {
      if (static_cast<int>(entry.second) == st.max_row) max_position = position;
      ++position;
    }
    EXPECT_EQ(max_position, gama_max);
  }
}

// Every network of data/gama with Gama's result next to it, in name order; prints one row
// of the agreement table per network.
TEST(GamaLocal, EveryNetworkOfDataGamaAgreesWithGama) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(DataPath(""))) {
    const std::filesystem::path& path = entry.path();
    if (path.extension() == ".gkf" && std::filesystem::exists(DataPath(path.stem().string() + ".xml"))) {
      names.push_back(path.stem().string());
    }
  }
  std::sort(names.begin(), names.end());
  EXPECT_GE(names.size(), 6u);
  std::ostringstream table;
  table << "| network | max |dcoord| mm | max sigma ratio | sigma0 ours / Gama | dof ours / Gama | "
           "test ours / Gama |\n";
  for (const std::string& name : names) {
    Agreement a;
    CompareWithGama(DataPath(name + ".gkf"), DataPath(name + ".xml"), &a);
    table << "| " << name << " | " << a.max_coordinate_mm << " | " << a.max_sigma_ratio << " | "
          << a.sigma0 << " / " << a.gama_sigma0 << " | " << a.dof << " / " << a.gama_dof << " | "
          << (a.passed ? "passed" : "failed") << " / " << (a.gama_passed ? "passed" : "failed")
          << " |\n";
  }
  std::cout << table.str();
}

// Gama's extern-azimuth-distance.gkf is azimuth-distance.gkf with `extern` labels on its two
// azimuths; Gama's result for it equals azimuth-distance.xml (σ0 9.9123357, dof 33, the same
// adjusted coordinates), so ours must match that file.
TEST(GamaLocal, ExternAttributesAreReadWithoutEffect) {
  Agreement a;
  CompareWithGama(DataPath("extern-azimuth-distance.gkf"), DataPath("azimuth-distance.xml"), &a);
  EXPECT_LT(a.max_coordinate_mm, 0.1);
  EXPECT_EQ(a.dof, 33);
}

// Gama's extern-tst-tetrahedron-3-gon.gkf: a 3-D free network with an `extern` label on every
// observation. Gama's result (extern-tst-tetrahedron-3-gon.xml, gama-local 2.02; its figures
// in data/SOURCES.md): dof 37, defect 1, σ0 51.791759, χ² test failed, and these coordinates.
TEST(GamaLocal, ExternTetrahedronAgreesWithGamasFigures) {
  SurveyNetwork net = io::ReadGamaLocal(DataPath("extern-tst-tetrahedron-3-gon.gkf"));
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged) << adj.reason;
  EXPECT_EQ(adj.statistics.degrees_of_freedom, 37);
  EXPECT_EQ(adj.statistics.defect, 1);
  EXPECT_NEAR(net.sigma0_apriori * adj.statistics.sigma0_ratio, 51.791759, 0.01 * 51.791759);
  EXPECT_FALSE(adj.statistics.chi2_passed);
  const std::map<std::string, std::map<char, double>> gama = {
      {"1", {{'z', -0.0177135264248634}}},
      {"2", {{'x', 3000.0087434691331509}, {'y', 0.0297875255750141}, {'z', 0.0177135264248634}}},
      {"3", {{'z', 0.0919950640650400}}},
      {"4", {{'x', 1500.0104715662891977}, {'y', 865.9905732048272284}, {'z', 2449.4975008629194235}}}};
  for (const auto& [id, coordinates] : gama) {
    const SurveyPoint& p = *net.Find(id);
    const Eigen::Vector2d xy = net.axes.XyFromEn(p.coords.head<2>());
    for (const auto& [axis, value] : coordinates) {
      const double ours = axis == 'x' ? xy.x() : axis == 'y' ? xy.y() : p.coords.z();
      EXPECT_NEAR(ours, value, 1e-4) << id << " " << axis;
    }
  }
}

// gama-local.gkf with a point whose z no observation determines (U1: x, y by one direction
// and one distance, no zenith angle) and a point seen by one direction only (U2): both
// coordinates are removed with a warning naming them, as Gama removes them, and the rest of
// the network is adjusted exactly as Gama adjusted gama-local.gkf (the added observations
// have no redundancy).
TEST(GamaLocal, UndeterminedCoordinatesAreRemovedWithAWarning) {
  const std::string gkf =
      std::string(MMBA_SOURCE_DIR) + "/tests/data/gama/gama-local-undetermined.gkf";
  Agreement a;
  CompareWithGama(gkf, DataPath("gama-local.xml"), &a, {"U1", "U2"});
  EXPECT_LT(a.max_coordinate_mm, 0.1);
  SurveyNetwork net = io::ReadGamaLocal(gkf);
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged);
  ASSERT_EQ(adj.removed_points.size(), 2u) << ResultSummary(gkf, net, adj);
  std::map<std::string, std::string> removed;
  for (const RemovedCoordinate& r : adj.removed_points) removed[r.point] = r.coordinates;
  EXPECT_EQ(removed["U1"], "z");
  EXPECT_EQ(removed["U2"], "xy");
  EXPECT_EQ(net.Find("U1")->z, CoordStatus::kRemoved);
  EXPECT_EQ(net.Find("U1")->xy, CoordStatus::kAdjusted);
  EXPECT_EQ(net.Find("U2")->xy, CoordStatus::kRemoved);
  EXPECT_TRUE(adj.statistics.IsFree(net.Find("U1")->coords.data()));
  EXPECT_FALSE(adj.statistics.IsFree(net.Find("U1")->coords.data() + 2));
  // The summary printed on the terminal names each removed coordinate with its line.
  const std::string summary = ResultSummary(gkf, net, adj);
  EXPECT_NE(summary.find("gama-local-undetermined.gkf:43: point U1: z removed from the adjustment"),
            std::string::npos) << summary;
  EXPECT_NE(summary.find("gama-local-undetermined.gkf:44: point U2: xy removed from the adjustment"),
            std::string::npos) << summary;
  // adjusted.json marks them.
  const nlohmann::json json = ResultToJson(gkf, net, adj);
  ASSERT_EQ(json["removed_points"].size(), 2u);
  for (const nlohmann::json& p : json["points"]) {
    if (p["id"] == "U1") {
      EXPECT_EQ(p["status_z"], "removed");
      EXPECT_EQ(p["status_x"], "adjusted");
      EXPECT_FALSE(p.contains("sigma_z"));
    }
    if (p["id"] == "U2") {
      EXPECT_EQ(p["status_x"], "removed");
      EXPECT_FALSE(p.contains("sigma_x"));
    }
  }
}

}  // namespace
}  // namespace mmba::survey

namespace mmba::survey {
namespace {

// Mikhail, Observations and Least Squares (1976), Example 7.4: level net, weights 1/length.
// The file's comment holds the textbook's adjusted heights (to 1 mm): B 825.220, C 835.535,
// D 809.535, E 830.846. Ours agree within 1.1 mm (D: 809.5339); the book rounds
// intermediate values, so the test allows 1.5 mm.
TEST(GamaLocal, Mikhail74AgainstTextbook) {
  SurveyNetwork net = io::ReadGamaLocal(DataPath("mikhail-7.4.gkf"));
  const SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged);
  EXPECT_EQ(adj.statistics.degrees_of_freedom, 4);
  const std::map<std::string, double> book = {
      {"B", 825.220}, {"C", 835.535}, {"D", 809.535}, {"E", 830.846}};
  for (const auto& [id, z] : book) EXPECT_NEAR(net.Find(id)->coords.z(), z, 1.5e-3) << id;
}

}  // namespace
}  // namespace mmba::survey

namespace mmba::survey {
namespace {

// The explicit covariance (normal-matrix inverse) equals ceres::Covariance (SuiteSparse QR).
TEST(GamaLocal, CeresCovarianceAgreesWithExplicitPath) {
  SurveyNetwork net = io::ReadGamaLocal(DataPath("gama-local.gkf"));
  SurveyAdjustment adj = AdjustNetwork(&net, SurveyAdjustOptions());
  ASSERT_TRUE(adj.converged);
  // Rebuild the problem at the solution and compare both paths.
  ceres::Problem problem;
  std::vector<std::unique_ptr<SurveyGroup>> groups = MakeSurveyGroups(&net);
  Scene scene;
  std::vector<const FactorGroup*> pointers;
  for (auto& g : groups) {
    g->AddResiduals(scene, problem);
    pointers.push_back(g.get());
  }
  SetSurveyParameterStates(&net, problem);
  stats::StatisticsOptions options;
  const stats::NetworkStatistics explicit_path = stats::ComputeStatistics(problem, pointers, options);
  options.use_ceres_covariance = true;
  const stats::NetworkStatistics ceres_path = stats::ComputeStatistics(problem, pointers, options);
  ASSERT_EQ(explicit_path.cofactor.rows(), ceres_path.cofactor.rows());
  const Eigen::MatrixXd explicit_q = explicit_path.cofactor.Dense();
  const double scale = explicit_q.cwiseAbs().maxCoeff();
  EXPECT_LT((explicit_q - ceres_path.cofactor.Dense()).cwiseAbs().maxCoeff(), 1e-8 * scale);
  EXPECT_EQ(explicit_path.max_row, ceres_path.max_row);
}

}  // namespace
}  // namespace mmba::survey
