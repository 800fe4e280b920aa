// Descriptor matching of the cloud registration: k nearest and mutual nearest neighbours.

#include "registration/cloud/descriptor_matching.h"

#include <algorithm>
#include <tuple>

namespace mmba::registration::internal {

Matching MatchDescriptors(const std::string& name, const Level& src, const Level& tgt,
                          const std::vector<int>& src_kp, const std::vector<int>& tgt_kp,
                          const Descriptors& ds, const Descriptors& dt, int k,
                          size_t max_pairs) {
  Matching m;
  m.descriptor = name;
  std::vector<float> src_data, tgt_data;
  const int dim = ds.dim;
  for (size_t i = 0; i < src_kp.size(); ++i) {
    if (!ds.valid[i]) continue;
    m.src_kp.push_back(src.points[src_kp[i]]);
    src_data.insert(src_data.end(), ds.data.begin() + i * dim, ds.data.begin() + (i + 1) * dim);
  }
  for (size_t i = 0; i < tgt_kp.size(); ++i) {
    if (!dt.valid[i]) continue;
    m.tgt_kp.push_back(tgt.points[tgt_kp[i]]);
    tgt_data.insert(tgt_data.end(), dt.data.begin() + i * dim, dt.data.begin() + (i + 1) * dim);
  }
  if (m.src_kp.size() < 3 || m.tgt_kp.size() < 3) return m;
  FeatureIndex tgt_index(tgt_data, dim), src_index(src_data, dim);
  std::vector<int> idx, back;
  std::vector<float> sq, back_sq;
  std::vector<std::tuple<int, float, int, int>> pairs;  // (not mutual, distance, src, tgt)
  m.src_to_tgt.resize(m.src_kp.size());
  for (size_t i = 0; i < m.src_kp.size(); ++i) {
    tgt_index.KNearest(&src_data[i * dim], k, &idx, &sq);
    m.src_to_tgt[i] = idx;
    if (idx.empty() || idx[0] < 0) continue;
    src_index.KNearest(&tgt_data[idx[0] * dim], 1, &back, &back_sq);
    const bool mutual = !back.empty() && back[0] == static_cast<int>(i);
    pairs.emplace_back(mutual ? 0 : 1, sq[0], static_cast<int>(i), idx[0]);
  }
  // Target-to-source nearest neighbours add the correspondences the other way round.
  for (size_t j = 0; j < m.tgt_kp.size(); ++j) {
    src_index.KNearest(&tgt_data[j * dim], 1, &back, &back_sq);
    if (back.empty() || back[0] < 0) continue;
    if (!m.src_to_tgt[back[0]].empty() && m.src_to_tgt[back[0]][0] == static_cast<int>(j)) {
      continue;  // already in as a mutual pair
    }
    pairs.emplace_back(1, back_sq[0], back[0], static_cast<int>(j));
  }
  std::sort(pairs.begin(), pairs.end());
  for (size_t i = 0; i < pairs.size() && i < max_pairs; ++i) {
    m.best_pairs.emplace_back(std::get<2>(pairs[i]), std::get<3>(pairs[i]));
  }
  return m;
}

}  // namespace mmba::registration::internal
