// Path guiding's sampling side: the learned distribution of the light arriving at a point,
// as the camera paths of nee and mis sample from it (src/integrators/path_guide.h learns it
// between passes; docs/estimators.md, "Path guiding").
//
// The structure is Müller, Gross and Novák's SD-tree ("Practical Path Guiding for Efficient
// Light-Transport Simulation", EGSR 2017): a binary tree over space whose leaves (cells)
// each hold a quadtree over directions. Directions map to the unit square by the
// cylindrical equal-area map, x = (cos θ + 1)/2, y = φ/2π, so a quadrant's share of the
// square is its share of the sphere's 4π. A quadtree node holds the energy of its four
// quadrants (normalised: the root's sum is 1 or 0); a quadrant is a leaf or a node of its
// own. Sampling descends from the root choosing quadrants in proportion to their energy,
// and the density of a direction is 4^depth · (the leaf's share) / 4π. A tree with no energy
// is uniform over the sphere.
//
// The guided continuation: where the roulette chose the diffuse lobe (probability P_d), the
// direction is drawn from the guide with probability α (the cell's: kGuideFractions) and from
// the lobe's
// own sampler otherwise (a one-sample mixture). The choice takes the first of the direction's
// two numbers, u₁ < α, stretched back over [0, 1) for the direction: each strategy's
// directions are then a stratified part of the sampler's points (a low-discrepancy sampler's
// (0,2) points restricted to a strip of u₁ are still stratified), and no decision draws new
// numbers. The
// direction's density is then P_d·(α·p_guide + (1 − α)·p_diffuse), in the throughput's
// divisor and in every MIS weight that names the diffuse lobe's density (the emitter
// sample's, and an emitter or the environment the path then hits: kernels/mis_weights.h).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "bsdf.h"

namespace cierzo {

// One node of the tree over space. A node with child > 0 is cut in half across `axis`
// (0, 1, 2) at the middle of its box, its halves being child (below) and child + 1; a node
// with child == 0 is a cell, number `cell`.
struct GuideSpatialNode {
    int32_t child = 0;
    uint32_t axis_or_cell = 0;
};

// One node of a cell's quadtree over directions: each quadrant's share of the cell's energy
// (x below 1/2 first, then y: q = qx + 2·qy) and its node, 0 for a leaf quadrant.
struct GuideDirectionNode {
    float energy[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    uint32_t child[4] = {0, 0, 0, 0};
};

// What the paths sample from: the tree over space, its box, each cell's quadtree root.
struct GuideView {
    const GuideSpatialNode* spatial = nullptr;
    const GuideDirectionNode* directions = nullptr;
    const uint32_t* roots = nullptr;   // per cell: its quadtree's root in `directions`
    const float* fractions = nullptr;  // per cell: α, the share of diffuse directions guided
    float lo[3] = {0.0f, 0.0f, 0.0f};
    float size[3] = {1.0f, 1.0f, 1.0f};
};

// The shares α of the diffuse lobe's directions a cell may draw from the guide. Each cell
// learns its own between passes (src/integrators/path_guide.h): the one whose estimated
// second moment of f·cos θ·L / p over the last iteration's records is least, 0 where the
// guide would not pay (after Müller's "Practical Path Guiding in Production", 2019, which
// learns it by gradient descent). kGuideFirstFraction is every cell's before that: 0, so the
// first guide is not sampled until its cell's records (drawn from the lobe, each with the
// guide's density at its direction) show that a share of it lowers the second moment. At
// ½, the iteration after the first training drew half its diffuse directions from a guide
// of 16 paths: 1.10-1.20× the error of unguided mis at equal paths on caustic, where
// starting at 0 gives 1.04-1.05×, and 0.77-0.84× on guiding/lantern's first indirect
// bounce, where starting at 0 gives 0.68-0.80× (docs/estimators.md, "Path guiding").
inline constexpr float kGuideFractions[] = {0.0f, 0.25f, 0.5f, 0.75f};
inline constexpr int kGuideFractionCount = 4;
inline constexpr float kGuideFirstFraction = 0.0f;

inline namespace CIERZO_ISA_NAMESPACE {

// The cell of point p (points outside the box go to the cell at its border).
inline uint32_t guide_cell(const GuideView& g, const Vec3f& p) {
    float lo[3] = {g.lo[0], g.lo[1], g.lo[2]};
    float size[3] = {g.size[0], g.size[1], g.size[2]};
    const float at[3] = {p.x, p.y, p.z};
    uint32_t n = 0;
    while (g.spatial[n].child > 0) {
        const uint32_t axis = g.spatial[n].axis_or_cell;
        size[axis] *= 0.5f;
        const float mid = lo[axis] + size[axis];
        const bool above = at[axis] >= mid;
        if (above) lo[axis] = mid;
        n = uint32_t(g.spatial[n].child) + (above ? 1u : 0u);
    }
    return g.spatial[n].axis_or_cell;
}

// atan2(y, x) within 2·10⁻⁶ radians, by a polynomial on [0, 1] and the octant (the direction
// map's own, used alike by sampling, densities and deposits; libm's took 4% of a guided
// render's time)
inline float guide_atan2(float y, float x) {
    const float ax = std::abs(x), ay = std::abs(y);
    const float big = std::max(ax, ay), small = std::min(ax, ay);
    const float t = big > 0.0f ? small / big : 0.0f;
    const float t2 = t * t;
    float r =
        t *
        (0.99997726f +
         t2 * (-0.33262347f +
               t2 * (0.19354346f + t2 * (-0.11643287f + t2 * (0.05265332f + t2 * -0.01172120f)))));
    if (ay > ax) r = float(0.5 * kPi) - r;
    if (x < 0.0f) r = float(kPi) - r;
    return y < 0.0f ? -r : r;
}

// The cylindrical equal-area map of a unit direction to [0, 1)² and back.
inline void direction_to_square(const Vec3f& d, float& x, float& y) {
    constexpr float kBelowOne = 0x1.fffffep-1f;
    const float z = std::clamp(d.z, -1.0f, 1.0f);
    x = std::min(0.5f * (z + 1.0f), kBelowOne);
    float phi = guide_atan2(d.y, d.x) * float(0.5 * kInvPi);
    if (phi < 0.0f) phi += 1.0f;
    y = std::min(std::max(phi, 0.0f), kBelowOne);
}
inline Vec3f square_to_direction(float x, float y) {
    const float cos_t = 2.0f * x - 1.0f;
    const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
    const float phi = float(2.0 * kPi) * y;
    return {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
}

// The guide's density (solid angle) of unit direction d in the quadtree at `root`.
inline float guide_pdf(const GuideView& g, uint32_t root, const Vec3f& d) {
    float x, y;
    direction_to_square(d, x, y);
    float density = 1.0f;
    for (uint32_t n = root;;) {
        const GuideDirectionNode& node = g.directions[n];
        const float total = (node.energy[0] + node.energy[1]) + (node.energy[2] + node.energy[3]);
        if (!(total > 0.0f)) break;  // (no energy: uniform from here)
        const uint32_t qx = x >= 0.5f ? 1u : 0u, qy = y >= 0.5f ? 1u : 0u;
        const uint32_t q = qx + 2u * qy;
        density *= 4.0f * node.energy[q] / total;
        if (node.child[q] == 0 || !(density > 0.0f)) break;
        x = 2.0f * x - float(qx), y = 2.0f * y - float(qy);
        n = node.child[q];
    }
    return density * float(0.25 * kInvPi);
}

// A direction drawn from the quadtree at `root` with (u1, u2) in [0, 1)², and its density
// (that of guide_pdf, computed on the way down).
inline Vec3f guide_sample(const GuideView& g, uint32_t root, float u1, float u2, float& pdf) {
    constexpr float kBelowOne = 0x1.fffffep-1f;
    float ox = 0.0f, oy = 0.0f, size = 1.0f, density = 1.0f;
    for (uint32_t n = root;;) {
        const GuideDirectionNode& node = g.directions[n];
        const float* e = node.energy;
        const float total = (e[0] + e[1]) + (e[2] + e[3]);
        if (!(total > 0.0f)) break;
        // The column (x) in proportion to its two quadrants, then the quadrant in it; each
        // number is stretched back over [0, 1) for what follows
        const float left = (e[0] + e[2]) / total;
        uint32_t qx = 0;
        if (u1 < left) {
            u1 = u1 / left;
        } else {
            qx = 1, u1 = (u1 - left) / (1.0f - left);
        }
        const float column = qx ? e[1] + e[3] : e[0] + e[2];
        const float lower = (qx ? e[1] : e[0]) / column;
        uint32_t qy = 0;
        if (u2 < lower) {
            u2 = u2 / lower;
        } else {
            qy = 1, u2 = (u2 - lower) / (1.0f - lower);
        }
        u1 = std::min(std::max(u1, 0.0f), kBelowOne), u2 = std::min(std::max(u2, 0.0f), kBelowOne);
        const uint32_t q = qx + 2u * qy;
        density *= 4.0f * e[q] / total;
        size *= 0.5f;
        ox += float(qx) * size, oy += float(qy) * size;
        if (node.child[q] == 0) break;
        n = node.child[q];
    }
    pdf = density * float(0.25 * kInvPi);
    return square_to_direction(ox + u1 * size, oy + u2 * size);
}

// The guide at one vertex, as the diffuse lobe's sampler and the MIS weights see it: the
// cell's quadtree and the share α of the lobe's directions it draws (0: not guided).
struct GuideAt {
    const GuideView* view = nullptr;
    uint32_t root = 0;
    float fraction = 0.0f;
    bool active() const { return fraction > 0.0f; }
    bool exists() const { return view != nullptr; }
    // The guided diffuse lobe's density of direction wi against the lobe's own, pdf_diffuse:
    // α·p_guide + (1 − α)·pdf_diffuse
    float mix(const Vec3f& wi, float pdf_diffuse) const {
        if (!active()) return pdf_diffuse;
        return fraction * guide_pdf(*view, root, wi) + (1.0f - fraction) * pdf_diffuse;
    }
};

inline GuideAt guide_at(const GuideView* g, const Vec3f& p) {
    if (!g) return {};
    const uint32_t cell = guide_cell(*g, p);
    return {g, g->roots[cell], g->fractions[cell]};
}

// The diffuse lobe's continuation where the guide is active: u1 below α picks the guide,
// above it the lobe's sampler; (u1 stretched over [0, 1), u2) draw the direction. The weight is
// f·cos θ / (P_d·p), p the mixture's density, 0 below the surface; `pdf` is P_d·p, the density MIS
// weighs the direction with, and guide_pdf_out and lobe_pdf_out the mixture's two densities.
inline Scatter<float> sample_guided_diffuse(const Bsdf<float>& m, const Vec3f& nf,
                                            const GuideAt& guide, float u1, float u2,
                                            float probability, bool cosine, float& pdf,
                                            float& guide_pdf_out, float& lobe_pdf_out) {
    constexpr float kBelowOne = 0x1.fffffep-1f;
    Vec3f dir;
    const float a = guide.fraction;
    if (u1 < a) {
        // (the density of the leaf it was drawn from: guide_pdf's, but for a direction that
        // rounding puts across a leaf's edge)
        dir = guide_sample(*guide.view, guide.root, std::min(u1 / a, kBelowOne), u2, guide_pdf_out);
    } else {
        u1 = std::min((u1 - a) / (1.0f - a), kBelowOne);
        dir = to_world(
            cosine ? sample_cosine_hemisphere(u1, u2) : sample_uniform_hemisphere(u1, u2), nf);
        guide_pdf_out = guide_pdf(*guide.view, guide.root, dir);
    }
    const float c = dot(dir, nf);
    const float pdf_diffuse = c > 0.0f ? (cosine ? c * float(kInvPi) : float(0.5 * kInvPi)) : 0.0f;
    lobe_pdf_out = pdf_diffuse;
    const float p = a * guide_pdf_out + (1.0f - a) * pdf_diffuse;
    pdf = probability * p;
    if (!(c > 0.0f) || !(pdf > 0.0f)) return {dir, Vec3f(0.0f)};
    return {dir, m.kd * (float(kInvPi) * c / pdf)};
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
