#include "mmba/registration/mi/mi_registration.h"

#include <sstream>

#include "registration/mi/mi_internal.h"

namespace mmba::registration::mi {

using internal::Fixed;

namespace {

// FNV-1a over raw bytes (Fowler, Noll & Vo).
class Fnv1a {
 public:
  void Bytes(const void* data, size_t size) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) hash_ = (hash_ ^ p[i]) * 1099511628211ull;
  }
  void Double(double v) { Bytes(&v, sizeof(v)); }
  void Int(int64_t v) { Bytes(&v, sizeof(v)); }
  void String(const std::string& s) {
    Int(static_cast<int64_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  template <typename Derived>
  void Matrix(const Eigen::MatrixBase<Derived>& m) {
    for (int r = 0; r < m.rows(); ++r) {
      for (int c = 0; c < m.cols(); ++c) Double(m(r, c));
    }
  }
  void Metric(const MetricValue& m) {
    for (double v : {m.mi, m.nmi, m.nid, m.joint_entropy, m.samples, m.lidar_samples, m.value}) {
      Double(v);
    }
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 14695981039346656037ull;
};

}  // namespace

uint64_t RegistrationResult::Digest() const {
  Fnv1a h;
  h.String(status);
  h.String(reason);
  h.Matrix(cam_from_lidar.ToMatrix4());
  h.Matrix(correction);
  h.Matrix(covariance);
  h.Matrix(covariance_laplace);
  h.Int(covariance_valid);
  h.Int(trusted);
  h.String(confidence_reason);
  const AcceptanceChecks& c = checks;
  h.Int(c.on_bound);
  h.Int(c.below_start);
  h.Int(c.weak_directions);
  h.Int(c.restarts_run);
  h.Int(c.scans_passed);
  h.Int(c.split_parts);
  for (double v : {c.sigma_px, c.effective_samples, c.sample_inflation, c.restart_spread_px,
                   c.restart_rms_px, c.restart_best_gain, c.mi_bits, c.mi_shuffled_bits,
                   c.mi_shuffled_sd_bits, c.mi_significance, c.split_spread_px,
                   c.variance_factor, c.variance_factor_halves, c.variance_factor_restarts,
                   c.sigma_px_calibrated, c.image_sigma_px, c.image_restart_spread_px,
                   c.image_split_spread_px, c.image_variance_factor,
                   c.image_sigma_px_calibrated, c.covariance_factor}) {
    h.Double(v);
  }
  h.Int(c.covariance_floor_directions);
  h.String(c.scans_reason);
  h.String(c.split_kind);
  h.Metric(metric_before);
  h.Metric(metric_after);
  h.Int(iterations);
  h.Int(evaluations);
  for (const StageStat& stage : stages) h.Int(stage.evaluations);
  for (const std::string& name : used_frames) h.String(name);
  for (const auto& [name, why] : rejected_frames) {
    h.String(name);
    h.String(why);
  }
  for (const RegistrationResult& frame : frame_results) h.Int(static_cast<int64_t>(frame.Digest()));
  return h.value();
}

std::string RegistrationResult::BriefReport() const {
  std::ostringstream out;
  out << "MI registration: " << status;
  if (!reason.empty()) out << " (" << reason << ")";
  out << "; correction t = (" << Fixed(correction[0]) << ", " << Fixed(correction[1]) << ", "
      << Fixed(correction[2]) << ") m, r/p/y = (" << Fixed(correction[3]) << ", "
      << Fixed(correction[4]) << ", " << Fixed(correction[5]) << ") deg; ";
  if (edge_term) {
    out << "edge score " << Fixed(edge_score_before, 3) << " -> " << Fixed(edge_score_after, 3)
        << " (1 = chance; MI weight " << Fixed(edge_mi_weight, 3) << "); sigma " << Fixed(sigma_deg, 3) << " deg, "
        << Fixed(100 * sigma_m, 1) << " cm; " << evaluations << " evaluations, " << Fixed(runtime_seconds, 2) << " s";
    return out.str();
  }
  // The values OUT.json holds (metric_before/after).
  out << MetricName(metric_kind) << " " << Fixed(ReportedMetric(metric_kind, metric_before.value), 5) << " -> "
      << Fixed(ReportedMetric(metric_kind, metric_after.value), 5)
      << (metric_kind == MetricKind::kNid ? " (minimised)" : " (maximised)") << "; "
      << iterations << " iterations, " << Fixed(runtime_seconds, 2) << " s";
  return out.str();
}

}  // namespace mmba::registration::mi
