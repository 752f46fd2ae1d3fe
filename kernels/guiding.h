// Path guiding's sampling side: the learned distribution of the light arriving at a point,
// as the camera paths of nee and mis sample from it (src/integrators/path_guide.h learns it
// between passes; docs/guiding.md).
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
// bounce, where starting at 0 gives 0.68-0.80× (docs/guiding.md).
inline constexpr float kGuideFractions[] = {0.0f, 0.25f, 0.5f, 0.75f};
inline constexpr int kGuideFractionCount = 4;
inline constexpr float kGuideFirstFraction = 0.0f;

inline namespace CIERZO_ISA_NAMESPACE {

// Every function below is written once for both integrators, on lanes T (kernels/lanes.h):
// float for a scalar path, a batch for the wavefront's K paths, each lane descending its own
// tree by gathers until every lane of `lanes` has reached its leaf. Lanes outside `lanes`
// read node 0 and keep what they had.

// The tables the descents gather from: a spatial node is two words (child, axis_or_cell),
// a direction node eight (four energies, four children).
inline const int32_t* spatial_words(const GuideView& g) {
    static_assert(sizeof(GuideSpatialNode) == 2 * sizeof(int32_t));
    return reinterpret_cast<const int32_t*>(g.spatial);
}
inline const float* direction_energies(const GuideView& g) {
    static_assert(sizeof(GuideDirectionNode) == 8 * sizeof(float));
    return reinterpret_cast<const float*>(g.directions);
}
inline const int32_t* direction_children(const GuideView& g) {
    return reinterpret_cast<const int32_t*>(g.directions) + 4;
}

// The cell of point p, on the lanes of `lanes` (points outside the box go to the cell at its
// border; other lanes get cell 0's).
template <class T>
I32<T> guide_cell(const GuideView& g, const Vec3<T>& p, const Mask<T>& lanes = Mask<T>(true)) {
    using I = I32<T>;
    const int32_t* words = spatial_words(g);
    T lo[3] = {T(g.lo[0]), T(g.lo[1]), T(g.lo[2])};
    T size[3] = {T(g.size[0]), T(g.size[1]), T(g.size[2])};
    const T at[3] = {p.x, p.y, p.z};
    I n(0);
    Mask<T> go = lanes;
    for (;;) {
        const I child = gather_table(words, n * I(2));
        go = go & mask_f32(child > I(0));
        if (none(go)) break;
        const I axis = gather_table(words, n * I(2) + I(1));
        Mask<T> above(false);
        for (int a = 0; a < 3; ++a) {
            const Mask<T> on = go & mask_f32(axis == I(a));
            size[a] = select(on, size[a] * T(0.5f), size[a]);
            const T mid = lo[a] + size[a];
            const Mask<T> up = on & (at[a] >= mid);
            lo[a] = select(up, mid, lo[a]);
            above = above | up;
        }
        n = select(mask_i32(go), child + select(mask_i32(above), I(1), I(0)), n);
    }
    return gather_table(words, n * I(2) + I(1));
}

// atan2(y, x) within 2·10⁻⁶ radians, by a polynomial on [0, 1] and the octant (the direction
// map's own, used alike by sampling, densities and deposits; libm's took 4% of a guided
// render's time)
template <class T>
T guide_atan2(const T& y, const T& x) {
    const T ax = abs(x), ay = abs(y);
    const T big = max(ax, ay), small = min(ax, ay);
    const T t = select(big > T(0.0f), small / big, T(0.0f));
    const T t2 = t * t;
    T r = t * (T(0.99997726f) +
               t2 * (T(-0.33262347f) +
                     t2 * (T(0.19354346f) +
                           t2 * (T(-0.11643287f) + t2 * (T(0.05265332f) + t2 * T(-0.01172120f))))));
    r = select(ay > ax, T(float(0.5 * kPi)) - r, r);
    r = select(x < T(0.0f), T(float(kPi)) - r, r);
    return select(y < T(0.0f), -r, r);
}

// The cylindrical equal-area map of a unit direction to [0, 1)² and back.
template <class T>
void direction_to_square(const Vec3<T>& d, T& x, T& y) {
    const T kBelowOne(0x1.fffffep-1f);
    const T z = min(max(d.z, T(-1.0f)), T(1.0f));
    x = min(T(0.5f) * (z + T(1.0f)), kBelowOne);
    T phi = guide_atan2(d.y, d.x) * T(float(0.5 * kInvPi));
    phi = select(phi < T(0.0f), phi + T(1.0f), phi);
    y = min(max(phi, T(0.0f)), kBelowOne);
}
template <class T>
Vec3<T> square_to_direction(const T& x, const T& y) {
    const T cos_t = T(2.0f) * x - T(1.0f);
    const T sin_t = sqrt(max(T(0.0f), T(1.0f) - cos_t * cos_t));
    const T phi = T(float(2.0 * kPi)) * y;
    return {sin_t * cos(phi), sin_t * sin(phi), cos_t};
}

// One quadtree node's four energies, gathered for each lane's node n, and their sum.
template <class T>
struct GuideQuadrants {
    T e[4];
    T total;
    GuideQuadrants(const GuideView& g, const I32<T>& n) {
        const float* energies = direction_energies(g);
        const I32<T> at = n * I32<T>(8);
        for (int q = 0; q < 4; ++q) e[q] = gather_table(energies, at + I32<T>(q));
        total = (e[0] + e[1]) + (e[2] + e[3]);
    }
    // The energy of quadrant qx + 2·qy
    T of(const Mask<T>& qx, const Mask<T>& qy) const {
        return select(qy, select(qx, e[3], e[2]), select(qx, e[1], e[0]));
    }
};

// One descent of the quadtree at `root` for each lane of `lanes`, which gives the density
// (solid angle) on the way down: the lanes of `draw` choose their quadrants by (u1, u2) in
// [0, 1)² (the column in proportion to its two quadrants, then the quadrant in it, each
// number stretched back over [0, 1) for what follows) and leave the direction drawn in
// `drawn`; the others follow unit direction d's point of the square. A sampled direction and
// another's density thus cost one descent together.
template <class T>
T guide_descend(const GuideView& g, const I32<T>& root, const Mask<T>& lanes, const Mask<T>& draw,
                T u1, T u2, const Vec3<T>& d, Vec3<T>& drawn) {
    using I = I32<T>;
    const int32_t* children = direction_children(g);
    const T kBelowOne(0x1.fffffep-1f);
    const Mask<T> point = !draw;  // (the lanes that follow d)
    T x(0.0f), y(0.0f);
    if (any(lanes & point)) direction_to_square(d, x, y);
    T ox(0.0f), oy(0.0f), size(1.0f), density(1.0f);
    I n = select(mask_i32(lanes), root, I(0));
    for (Mask<T> go = lanes; any(go);) {
        const GuideQuadrants<T> node(g, n);
        const T* e = node.e;
        go = go & (node.total > T(0.0f));  // (no energy: uniform from here)
        const T left = (e[0] + e[2]) / node.total;
        const Mask<T> qx = (draw & (u1 >= left)) | (point & (x >= T(0.5f)));
        const T column = select(qx, e[1] + e[3], e[0] + e[2]);
        const T lower = select(qx, e[1], e[0]) / column;
        const Mask<T> qy = (draw & (u2 >= lower)) | (point & (y >= T(0.5f)));
        density = select(go, density * (T(4.0f) * node.of(qx, qy) / node.total), density);
        const Mask<T> drawing = go & draw;
        if (any(drawing)) {
            const T u1s = select(qx, (u1 - left) / (T(1.0f) - left), u1 / left);
            const T u2s = select(qy, (u2 - lower) / (T(1.0f) - lower), u2 / lower);
            u1 = select(drawing, min(max(u1s, T(0.0f)), kBelowOne), u1);
            u2 = select(drawing, min(max(u2s, T(0.0f)), kBelowOne), u2);
            const T half = size * T(0.5f);
            ox = select(drawing & qx, ox + half, ox), oy = select(drawing & qy, oy + half, oy);
            size = select(drawing, half, size);
        }
        const I q = select(mask_i32(qx), I(1), I(0)) + select(mask_i32(qy), I(2), I(0));
        const I child = gather_table(children, n * I(8) + q);
        // (a followed direction whose quadrant holds nothing: density 0 from here)
        go = go & mask_f32(child != I(0)) & (draw | (density > T(0.0f)));
        const Mask<T> deeper = go & point;
        x = select(deeper, T(2.0f) * x - select(qx, T(1.0f), T(0.0f)), x);
        y = select(deeper, T(2.0f) * y - select(qy, T(1.0f), T(0.0f)), y);
        n = select(mask_i32(go), child, n);
    }
    if (any(draw)) drawn = square_to_direction(ox + u1 * size, oy + u2 * size);
    return density * T(float(0.25 * kInvPi));
}

// The guide's density (solid angle) of unit direction d in the quadtree at `root`, on the
// lanes of `lanes` (the others: 1/4π).
template <class T>
T guide_pdf(const GuideView& g, const I32<T>& root, const Vec3<T>& d,
            const Mask<T>& lanes = Mask<T>(true)) {
    Vec3<T> unused;
    return guide_descend(g, root, lanes, Mask<T>(false), T(0.0f), T(0.0f), d, unused);
}

// A direction drawn from the quadtree at `root` with (u1, u2) in [0, 1)², on the lanes of
// `lanes`, and its density (that of guide_pdf, computed on the way down).
template <class T>
Vec3<T> guide_sample(const GuideView& g, const I32<T>& root, T u1, T u2, T& pdf,
                     const Mask<T>& lanes = Mask<T>(true)) {
    Vec3<T> drawn(T(0.0f));
    pdf = guide_descend(g, root, lanes, lanes, u1, u2, Vec3<T>(T(0.0f)), drawn);
    return drawn;
}

// The guide at one vertex (per lane), as the diffuse lobe's sampler and the MIS weights see
// it: the cell's quadtree and the share α of the lobe's directions it draws (0: not guided).
template <class T>
struct GuideAt {
    const GuideView* view = nullptr;
    I32<T> root = I32<T>(0);
    T fraction = T(0.0f);
    Mask<T> active() const { return fraction > T(0.0f); }
    bool exists() const { return view != nullptr; }
    // The guided diffuse lobe's density of direction wi against the lobe's own, pdf_diffuse:
    // α·p_guide + (1 − α)·pdf_diffuse
    T mix(const Vec3<T>& wi, const T& pdf_diffuse) const {
        const Mask<T> on = active();
        if (!view || none(on)) return pdf_diffuse;
        const T mixed =
            fraction * guide_pdf(*view, root, wi, on) + (T(1.0f) - fraction) * pdf_diffuse;
        return select(on, mixed, pdf_diffuse);
    }
};

// The guide at point p on the lanes of `lanes` (the others, and every lane without a guide:
// not guided).
template <class T>
GuideAt<T> guide_at(const GuideView* g, const Vec3<T>& p, const Mask<T>& lanes = Mask<T>(true)) {
    if (!g || none(lanes)) return {};
    const I32<T> cell = guide_cell(*g, p, lanes);
    return {g, gather_table(reinterpret_cast<const int32_t*>(g->roots), cell),
            select(lanes, gather_table(g->fractions, cell), T(0.0f))};
}

// The diffuse lobe's f·cos θ towards wi (nsf: the shading normal on the arriving side), which
// a diffuse record's share α learns from (PathGuide::SelectionSample).
template <class T>
Vec3<T> diffuse_f_cos(const Bsdf<T>& m, const Vec3<T>& wi, const Vec3<T>& nsf) {
    return m.kd * (max(dot(wi, nsf), T(0.0f)) * T(float(kInvPi)));
}

// The diffuse lobe's continuation where the guide is active: u1 below α picks the guide,
// above it the lobe's sampler; (u1 stretched over [0, 1), u2) draw the direction. The weight is
// f·cos θ / (P_d·p), p the mixture's density, 0 below the surface; `pdf` is P_d·p, the density MIS
// weighs the direction with, and guide_pdf_out and lobe_pdf_out the mixture's two densities.
// (Lanes where the guide is not active draw from the lobe alone, with u1 as it is.)
template <class T>
Scatter<T> sample_guided_diffuse(const Bsdf<T>& m, const Vec3<T>& nf, const GuideAt<T>& guide,
                                 const T& u1, const T& u2, const T& probability, bool cosine,
                                 T& pdf, T& guide_pdf_out, T& lobe_pdf_out) {
    const T kBelowOne(0x1.fffffep-1f);
    const T a = guide.fraction;
    const Mask<T> active = guide.active();
    const Mask<T> from_guide = u1 < a;
    const T ul = min((u1 - a) / (T(1.0f) - a), kBelowOne);
    Vec3<T> dir =
        to_world(cosine ? sample_cosine_hemisphere(ul, u2) : sample_uniform_hemisphere(ul, u2), nf);
    // One descent: the guide's direction where it draws (and the density of the leaf it was
    // drawn from: guide_pdf's, but for a direction that rounding puts across a leaf's edge),
    // the guide's density of the lobe's direction elsewhere
    guide_pdf_out = T(0.0f);
    if (any(active)) {
        Vec3<T> drawn = dir;
        guide_pdf_out = select(active,
                               guide_descend(*guide.view, guide.root, active, from_guide,
                                             min(u1 / a, kBelowOne), u2, dir, drawn),
                               T(0.0f));
        dir = select(from_guide, drawn, dir);
    }
    const T c = dot(dir, nf);
    const T pdf_diffuse =
        select(c > T(0.0f), cosine ? c * T(float(kInvPi)) : T(float(0.5 * kInvPi)), T(0.0f));
    lobe_pdf_out = pdf_diffuse;
    const T p = a * guide_pdf_out + (T(1.0f) - a) * pdf_diffuse;
    pdf = probability * p;
    const Mask<T> ok = (c > T(0.0f)) & (pdf > T(0.0f));
    const T factor = select(ok, T(float(kInvPi)) * c / select(ok, pdf, T(1.0f)), T(0.0f));
    return {dir, m.kd * factor};
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
