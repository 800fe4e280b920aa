#pragma once

// Pearson's product-moment correlation of paired samples (header only: the colour-agreement
// benchmark and the adjustment's colour tests share it).

#include <cmath>
#include <utility>
#include <vector>

namespace mmba::stats {

/// r = Σ(a − ā)(b − b̄) / √(Σ(a − ā)² · Σ(b − b̄)²); NaN for fewer than two pairs or a constant side.
inline double Pearson(const std::vector<std::pair<double, double>>& pairs) {
  if (pairs.size() < 2) return NAN;
  double ma = 0, mb = 0;
  for (const auto& [a, b] : pairs) ma += a, mb += b;
  ma /= pairs.size();
  mb /= pairs.size();
  double sab = 0, saa = 0, sbb = 0;
  for (const auto& [a, b] : pairs) sab += (a - ma) * (b - mb), saa += (a - ma) * (a - ma), sbb += (b - mb) * (b - mb);
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : NAN;
}

}  // namespace mmba::stats
