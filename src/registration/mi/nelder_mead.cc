#include "mmba/registration/mi/nelder_mead.h"

#include <algorithm>
#include <array>
#include <numeric>

namespace mmba::registration::mi {

NelderMeadResult MaximizeNelderMead(const std::function<double(const Vector6d&)>& f,
                                    const Vector6d& x0, const NelderMeadOptions& options) {
  constexpr int kN = 6;
  // Lagarias et al. 1998: reflection 1, expansion 2, contraction 0.5, shrink 0.5.
  constexpr double kReflect = 1.0, kExpand = 2.0, kContract = 0.5, kShrink = 0.5;
  NelderMeadResult result;
  auto project = [&](Vector6d x) {
    return x.cwiseMax(options.lower).cwiseMin(options.upper).eval();
  };
  auto eval = [&](const Vector6d& x) {
    ++result.evaluations;
    return f(x);
  };
  std::array<Vector6d, kN + 1> simplex;
  std::array<double, kN + 1> values;
  simplex[0] = project(x0);
  values[0] = eval(simplex[0]);
  for (int i = 0; i < kN; ++i) {
    Vector6d x = simplex[0];
    x[i] += options.initial_step[i];
    // A vertex beyond the upper bound steps the other way instead of collapsing on x0.
    if (x[i] > options.upper[i]) x[i] = simplex[0][i] - options.initial_step[i];
    simplex[i + 1] = project(x);
    values[i + 1] = eval(simplex[i + 1]);
  }
  std::array<int, kN + 1> order;
  for (result.iterations = 0; result.iterations < options.max_iterations; ++result.iterations) {
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return values[a] > values[b]; });
    const int best = order[0], worst = order[kN], second_worst = order[kN - 1];
    double x_spread = 0, f_spread = 0;
    for (int i = 1; i <= kN; ++i) {
      x_spread = std::max(x_spread, (simplex[order[i]] - simplex[best]).cwiseAbs().maxCoeff());
      f_spread = std::max(f_spread, std::abs(values[order[i]] - values[best]));
    }
    if (x_spread <= options.parameter_tolerance && f_spread <= options.function_tolerance) {
      result.converged = true;
      break;
    }
    Vector6d centroid = Vector6d::Zero();
    for (int i = 0; i < kN; ++i) centroid += simplex[order[i]];
    centroid /= kN;
    const Vector6d reflected = project(centroid + kReflect * (centroid - simplex[worst]));
    const double f_reflected = eval(reflected);
    if (f_reflected > values[best]) {
      const Vector6d expanded = project(centroid + kExpand * (reflected - centroid));
      const double f_expanded = eval(expanded);
      if (f_expanded > f_reflected) {
        simplex[worst] = expanded;
        values[worst] = f_expanded;
      } else {
        simplex[worst] = reflected;
        values[worst] = f_reflected;
      }
      continue;
    }
    if (f_reflected > values[second_worst]) {
      simplex[worst] = reflected;
      values[worst] = f_reflected;
      continue;
    }
    // Contraction: outside if the reflection improved on the worst, else inside.
    const bool outside = f_reflected > values[worst];
    const Vector6d contracted =
        outside ? project(centroid + kContract * (reflected - centroid))
                : project(centroid + kContract * (simplex[worst] - centroid));
    const double f_contracted = eval(contracted);
    if (f_contracted > (outside ? f_reflected : values[worst])) {
      simplex[worst] = contracted;
      values[worst] = f_contracted;
      continue;
    }
    for (int i = 1; i <= kN; ++i) {
      const int k = order[i];
      simplex[k] = project(simplex[best] + kShrink * (simplex[k] - simplex[best]));
      values[k] = eval(simplex[k]);
    }
  }
  const int best = static_cast<int>(std::max_element(values.begin(), values.end()) -
                                    values.begin());
  result.x = simplex[best];
  result.value = values[best];
  return result;
}

}  // namespace mmba::registration::mi
