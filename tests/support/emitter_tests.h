// What the emitter sampling tests share: scenes of a few emitters, 24-bit uniform numbers
// like the estimator's, and bins of equal measure for directions about an axis and for
// points on a triangle, computed here rather than by the samplers under test.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "kernels/vec3.h"
#include "scene/scene_json.h"
#include "support/statistics.h"

namespace cierzo::test {

// A scene of the given objects (JSON) with emitters, for its emitter table: materials L
// (Le 2, 1, 0.5), M (Le 7) and w (diffuse, not an emitter).
inline Scene emitter_scene(const std::string& objects) {
    return parse_scene(R"({"camera": {"position": [0, 0, -5], "look_at": [0, 0, 0], "vfov": 40},
        "materials": {"L": {"emission": [2, 1, 0.5]}, "M": {"emission": 7}, "w": {"kd": 0.5}},
        "objects": [)" + objects +
                           "]}",
                       "/tmp/emitters.json");
}

// Uniform numbers in [0, 1) with 24 bits, as the estimator's, from a fixed seed.
struct Uniforms {
    std::mt19937 rng{12345};
    std::uniform_real_distribution<float> u{0.0f, 1.0f};
    float operator()() { return std::floor(u(rng) * 16777216.0f) * 0x1.0p-24f; }
};

// A direction about a unit axis, in double: 1 - cos θ (from sin²θ = |dir × axis|² where
// 1 - dot would cancel), cos θ, and φ in [0, 2π) in a frame built here (not the samplers').
struct Polar {
    double one_minus_cos, cos_theta, phi;
};
inline Polar polar_about(const Vec3f& dir, const Vec3f& axis) {
    const Vec3f helper = std::abs(axis.x) < 0.9f ? Vec3f(1, 0, 0) : Vec3f(0, 1, 0);
    const Vec3f t = normalize(cross(axis, helper)), b = cross(axis, t);
    const double cx = double(dir.y) * axis.z - double(dir.z) * axis.y;
    const double cy = double(dir.z) * axis.x - double(dir.x) * axis.z;
    const double cz = double(dir.x) * axis.y - double(dir.y) * axis.x;
    const double sin2 = cx * cx + cy * cy + cz * cz;
    const double cos_t = double(dir.x) * axis.x + double(dir.y) * axis.y + double(dir.z) * axis.z;
    const double phi = std::atan2(double(dot(dir, b)), double(dot(dir, t))) + M_PI;
    return {cos_t > 0 ? sin2 / (1.0 + cos_t) : 1.0 - cos_t, cos_t, phi};
}

// Bin k of n equal parts of [0, 1) that x falls in (the ends clamped).
inline int part_of(double x, int n) { return std::min(n - 1, std::max(0, int(x * n))); }

// Equal-solid-angle bins of a direction around `axis` within a cone of 1 - cos = one_minus
// (2: the whole sphere): 16 bands of 1 - cos θ, 16 sectors of φ.
inline int cone_bin(const Vec3f& dir, const Vec3f& axis, double one_minus) {
    const Polar a = polar_about(dir, axis);
    return part_of(a.one_minus_cos / one_minus, 16) * 16 + part_of(a.phi / (2.0 * M_PI), 16);
}

// The barycentric coordinates (of v1 and v2) of a point p of the triangle v0 v1 v2, by least
// squares on the two edges.
struct Barycentrics {
    double beta, gamma;
};
inline Barycentrics barycentrics_of(const Vec3f& p, const Vec3f& v0, const Vec3f& v1,
                                    const Vec3f& v2) {
    const Vec3f q = p - v0, e1 = v1 - v0, e2 = v2 - v0;
    const double a11 = dot(e1, e1), a12 = dot(e1, e2), a22 = dot(e2, e2);
    const double b1 = dot(q, e1), b2 = dot(q, e2), det = a11 * a22 - a12 * a12;
    return {(b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det};
}

// The triangle cut into k² congruent sub-triangles of equal area: the one of the point with
// barycentrics b, numbered 0 … k² - 1.
inline int triangle_cell(const Barycentrics& b, int k) {
    // Cell (i, j) of the k × k grid of the unit right triangle, upper or lower half
    const double fb = std::clamp(b.beta, 0.0, 1.0 - 1e-9) * k;
    const double fg = std::clamp(b.gamma, 0.0, 1.0 - 1e-9) * k;
    const int i = std::min(int(fb), k - 1), j = std::min(int(fg), k - 1 - i);
    const bool upper = (fb - i) + (fg - j) > 1.0;
    // Row i has 2(k - i) - 1 cells
    int index = 0;
    for (int r = 0; r < i; ++r) index += 2 * (k - r) - 1;
    index += 2 * j + (upper ? 1 : 0);
    return std::min(index, k * k - 1);
}

// The triangle the emitter tests sample, and a histogram of points on it over its k² cells,
// to compare with the uniform density by chi-square.
struct TriangleHistogram {
    static constexpr int k = 8;
    const Vec3f v0{-1.0f, 0.5f, 2.0f}, v1{1.5f, 0.2f, 2.5f}, v2{0.0f, 2.0f, 1.0f};
    std::vector<double> observed = std::vector<double>(size_t(k * k), 0.0);

    // The triangle as a scene object of `material`
    static std::string object(const std::string& material) {
        return R"({"type": "triangle", "vertices": [[-1, 0.5, 2], [1.5, 0.2, 2.5], [0, 2, 1]],
                   "material": ")" +
               material + R"("})";
    }
    double area() const { return 0.5 * double(length(cross(v1 - v0, v2 - v0))); }
    Vec3f normal() const { return normalize(cross(v1 - v0, v2 - v0)); }
    // Counts p; false where p is not on the triangle
    bool add(const Vec3f& p) {
        const Barycentrics b = barycentrics_of(p, v0, v1, v2);
        if (!(b.beta >= -1e-5 && b.gamma >= -1e-5 && b.beta + b.gamma <= 1.0 + 1e-5)) return false;
        observed[size_t(triangle_cell(b, k))] += 1.0;
        return true;
    }
    // Pearson's statistic against equal counts, and its critical value
    std::pair<double, double> chi_square_test() const {
        return chi_square_test(std::vector<double>(observed.size(), 1.0 / (k * k)));
    }
    // The same against the probabilities p of the cells
    std::pair<double, double> chi_square_test(const std::vector<double>& p) const {
        double n = 0.0;
        for (const double o : observed) n += o;
        std::vector<double> expected(p.size());
        for (size_t i = 0; i < p.size(); ++i) expected[i] = n * p[i];
        const auto [stat, dof] = chi_square(observed, expected);
        return {stat, chi_square_critical(dof)};
    }
    // The solid angle each cell subtends at x, in double (Van Oosterom and Strackee's
    // formula, computed here), cell by cell in triangle_cell's numbering
    std::vector<double> cell_solid_angles(const Vec3f& x) const {
        const auto point = [&](double b, double g) {
            const double p[3] = {v0.x + b * (v1.x - v0.x) + g * (v2.x - v0.x),
                                 v0.y + b * (v1.y - v0.y) + g * (v2.y - v0.y),
                                 v0.z + b * (v1.z - v0.z) + g * (v2.z - v0.z)};
            std::array<double, 3> d{p[0] - x.x, p[1] - x.y, p[2] - x.z};
            const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (double& c : d) c /= len;
            return d;
        };
        const auto dotd = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
            return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        };
        const auto omega = [&](double b0, double g0, double b1, double g1, double b2, double g2) {
            const auto a = point(b0 / k, g0 / k), b = point(b1 / k, g1 / k),
                       c = point(b2 / k, g2 / k);
            const std::array<double, 3> bc{b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2],
                                           b[0] * c[1] - b[1] * c[0]};
            return 2.0 *
                   std::atan2(std::abs(dotd(a, bc)), 1.0 + dotd(a, b) + dotd(b, c) + dotd(c, a));
        };
        std::vector<double> out;
        for (int i = 0; i < k; ++i)
            for (int j = 0; j < k - i; ++j) {
                out.push_back(omega(i, j, i + 1, j, i, j + 1));  // lower half of the square
                if (j < k - 1 - i) out.push_back(omega(i + 1, j, i + 1, j + 1, i, j + 1));
            }
        return out;
    }
};

}  // namespace cierzo::test
