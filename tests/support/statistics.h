// Statistical helpers for the Monte Carlo tests: running mean with standard error, and the
// chi-square critical value used to accept a histogram against its expected counts.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace cierzo::test {

// Mean and standard error of the mean of a stream of samples.
struct MeanEstimate {
    double sum = 0.0, sum_sq = 0.0;
    uint64_t n = 0;
    void add(double v) { sum += v, sum_sq += v * v, ++n; }
    double mean() const { return sum / double(n); }
    double standard_error() const {
        const double m = mean();
        const double var = (sum_sq / double(n) - m * m) * double(n) / double(n - 1);
        return std::sqrt(std::max(var, 0.0) / double(n));
    }
};

// Upper critical value of chi-square with k degrees of freedom at significance 1e-4
// (Wilson–Hilferty approximation; z = 3.719).
inline double chi_square_critical(int k) {
    const double z = 3.719;
    const double h = 2.0 / (9.0 * k);
    const double c = 1.0 - h + z * std::sqrt(h);
    return k * c * c * c;
}

// Pearson's statistic of observed counts against expected counts; bins with expected < 5
// are merged into their neighbour so the approximation holds. Returns {statistic, dof}.
inline std::pair<double, int> chi_square(const std::vector<double>& observed,
                                         const std::vector<double>& expected) {
    double stat = 0.0, obs = 0.0, exp = 0.0;
    int bins = 0;
    for (size_t i = 0; i < observed.size(); ++i) {
        obs += observed[i];
        exp += expected[i];
        if (exp < 5.0 && i + 1 < observed.size()) continue;
        stat += (obs - exp) * (obs - exp) / std::max(exp, 1e-12);
        ++bins;
        obs = exp = 0.0;
    }
    return {stat, bins - 1};
}

}  // namespace cierzo::test
