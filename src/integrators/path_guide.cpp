// The path guide's learning (path_guide.h).
#include "integrators/path_guide.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>

namespace cierzo {

using U128 = GuideSum;

// (its children apart, in learning_child_: a deposit's descent reads only those, and they
// stay in cache where the sums, a line per node, would not)
struct alignas(64) PathGuide::LearnNode {
    std::atomic<uint64_t> low[4];
    std::atomic<uint64_t> high[4];  // the carries out of `low`
    U128 sum(int q) const {
        return (U128(high[q].load(std::memory_order_relaxed)) << 64) |
               U128(low[q].load(std::memory_order_relaxed));
    }
};

// A quadtree as training builds it: nodes[0] is the root; child 0 is a leaf quadrant.
struct PathGuide::Shape {
    struct Node {
        uint32_t child[4] = {0, 0, 0, 0};
    };
    std::vector<Node> nodes;
};

struct PathGuide::CellTrees {
    std::vector<GuideDirectionNode> sampled;  // nodes[0] the root, children relative
    Shape learning;
};

namespace {

// Floats as unsigned integers in the floats' order, for atomic minima and maxima.
uint32_t ordered(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
// The box's histograms: a coordinate's bin is the top 12 bits of its ordered bits (sign,
// exponent and 3 bits of mantissa: bins an eighth of a binade wide, over every float)
constexpr int kBinShift = 20;
constexpr size_t kBoxBins = size_t(1) << (32 - kBinShift);
// A robust box: the coordinates between these quantiles of the first iteration's vertices
// per axis (paths that leave a room through an opening reach its infinite floor hundreds of
// units away; a box around those would leave the room a cell or two)
constexpr double kBoxQuantile = 0.005;

float from_ordered(uint32_t u) {
    u = (u & 0x80000000u) ? (u & 0x7fffffffu) : ~u;
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

// L/p in fixed point: 2^-32 resolution, at most 2^30 (a guide needs no more: the value
// only shapes a sampling density, so clamping it biases nothing)
uint64_t quantise(double value) {
    if (!(value > 0.0)) return 0;  // (NaN too)
    const double v = std::min(value, 0x1.0p30);
    return uint64_t(v * 0x1.0p32);
}

uint32_t bits_of(float f) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}
// (SplitMix64's finaliser)
uint64_t mix64(uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

// A shape that subdivides the quadrants of the node `at` of a tree whose quadrant shares
// are `share` (null: below the tree, where a quadrant's share is a quarter of its node's),
// while a quadrant holds more than `rho` of the whole, to `max_depth` levels, within
// `budget` nodes.
void subdivide(PathGuide::Shape& out, const std::vector<std::array<double, 4>>* share,
               const std::vector<std::array<uint32_t, 4>>* children, uint32_t at, double node_share,
               int depth, double rho, int max_depth) {
    const size_t self = out.nodes.size();
    out.nodes.emplace_back();
    for (int q = 0; q < 4; ++q) {
        const double s = share ? (*share)[at][size_t(q)] : node_share * 0.25;
        if (!(s > rho) || depth >= max_depth) continue;
        const bool below = share && (*children)[at][size_t(q)] != 0;
        const uint32_t child = uint32_t(out.nodes.size());
        subdivide(out, below ? share : nullptr, children, below ? (*children)[at][size_t(q)] : 0, s,
                  depth + 1, rho, max_depth);
        out.nodes[self].child[q] = child;
    }
}

}  // namespace

namespace {
std::atomic<uint64_t> next_serial{1};
}  // namespace

PathGuide::Learner& PathGuide::learner() {
    thread_local uint64_t serial = 0;
    thread_local Learner* mine = nullptr;
    if (serial != serial_) {
        std::lock_guard lock(learners_mutex_);
        learners_.push_back(std::make_unique<Learner>());
        for (std::vector<CellSums>& c : learners_.back()->cells)
            c.assign(learning_roots_.size(), CellSums{});
        if (!box_set_)
            for (std::vector<uint64_t>& b : learners_.back()->bins) b.assign(3 * kBoxBins, 0);
        mine = learners_.back().get();
        serial = serial_;
        Learner* none = nullptr;
        first_.compare_exchange_strong(none, mine);
    }
    return *mine;
}

PathGuide::PathGuide(bool merge, bool filter, float first_fraction, uint64_t learn_records)
    : serial_(next_serial.fetch_add(1)),
      merge_(merge),
      filter_(filter),
      learn_records_(learn_records) {
    committed_bins_.assign(3 * kBoxBins, 0);
    // One cell; its first learning tree three levels deep (64 quadrants) and no sampled tree
    Shape first;
    subdivide(first, nullptr, nullptr, 0, 1.0, 1, 1.0 / 64.0, kGuideMaxDepth);
    allocate_learning({first});
    directions_.assign(1, GuideDirectionNode{});
    roots_.assign(1, 0);
    fractions_.assign(1, first_fraction);
    update_view();
}

PathGuide::~PathGuide() = default;

void PathGuide::allocate_learning(const std::vector<Shape>& trees) {
    size_t total = 0;
    for (const Shape& t : trees) total += t.nodes.size();
    learning_child_ = std::make_unique<uint32_t[]>(total * 4);
    learning_roots_.assign(trees.size(), 0);
    size_t at = 0;
    for (size_t c = 0; c < trees.size(); ++c) {
        learning_roots_[c] = uint32_t(at);
        for (const Shape::Node& n : trees[c].nodes) {
            for (int q = 0; q < 4; ++q)
                learning_child_[at * 4 + size_t(q)] =
                    n.child[q] ? uint32_t(learning_roots_[c] + n.child[q]) : 0u;
            ++at;
        }
    }
    resize_sums(total, trees.size());
}

void PathGuide::resize_sums(size_t nodes, size_t cells) {
    learning_size_ = nodes;
    for (std::unique_ptr<LearnNode[]>& slot : learning_) {
        slot = std::make_unique<LearnNode[]>(nodes);
        for (size_t n = 0; n < nodes; ++n)
            for (int q = 0; q < 4; ++q) {
                slot[n].low[q].store(0, std::memory_order_relaxed);
                slot[n].high[q].store(0, std::memory_order_relaxed);
            }
    }
    committed_.assign(nodes * 4, 0);
    committed_cells_.assign(cells, CellTotals{});
    std::lock_guard lock(learners_mutex_);
    for (const std::unique_ptr<Learner>& l : learners_)
        for (std::vector<CellSums>& c : l->cells) c.assign(cells, CellSums{});
}

void PathGuide::commit_slot(int slot) {
    LearnNode* nodes = learning_[slot].get();
    for (size_t n = 0; n < learning_size_; ++n)
        for (int q = 0; q < 4; ++q) {
            committed_[n * 4 + size_t(q)] += nodes[n].sum(q);
            nodes[n].low[q].store(0, std::memory_order_relaxed);
            nodes[n].high[q].store(0, std::memory_order_relaxed);
        }
    std::lock_guard lock(learners_mutex_);
    for (const std::unique_ptr<Learner>& l : learners_) {
        std::vector<CellSums>& cells = l->cells[slot];
        for (size_t c = 0; c < cells.size(); ++c) {
            CellTotals& t = committed_cells_[c];
            t.count += cells[c].count;
            for (int k = 0; k < kGuideFractionCount; ++k)
                t.moment[k] += (U128(cells[c].high[k]) << 64) | U128(cells[c].low[k]);
            cells[c] = CellSums{};
        }
        std::vector<uint64_t>& bins = l->bins[slot];
        for (size_t i = 0; i < bins.size() && i < committed_bins_.size(); ++i)
            committed_bins_[i] += bins[i], bins[i] = 0;
    }
}

void PathGuide::commit_pass(int32_t pass) { commit_slot(int(pass & 1)); }

void PathGuide::update_view() {
    view_.spatial = spatial_.data();
    view_.directions = directions_.data();
    view_.roots = roots_.data();
    view_.fractions = fractions_.data();
    for (int a = 0; a < 3; ++a) view_.lo[a] = lo_[a], view_.size[a] = size_[a];
}

namespace {

// Adds q to the 128-bit sum kept as (low, high): exact, in any order
inline void add_exact(std::atomic<uint64_t>& low, std::atomic<uint64_t>& high, uint64_t q) {
    const uint64_t before = low.fetch_add(q, std::memory_order_relaxed);
    if (before + q < before) high.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

void PathGuide::deposit(int32_t pass, const GuideRecord& r) {
    const auto part = [](float g, float t) { return t > 0.0f ? g / t : 0.0f; };
    const Vec3f li(part(r.gathered[0], r.throughput[0]), part(r.gathered[1], r.throughput[1]),
                   part(r.gathered[2], r.throughput[2]));
    const auto luminance = [](const Vec3f& c) {
        return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z;
    };
    const float l = luminance(li);
    SelectionSample s;
    if (r.selection)
        s = {luminance(Vec3f(r.f_cos[0], r.f_cos[1], r.f_cos[2]) * li), r.guide_pdf, r.lobe_pdf,
             r.fraction};
    deposit(pass, Vec3f(r.p[0], r.p[1], r.p[2]), Vec3f(r.dir[0], r.dir[1], r.dir[2]),
            r.density > 0.0f ? l / r.density : 0.0f, r.selection ? &s : nullptr);
}

void PathGuide::deposit(int32_t pass, const Vec3f& p, const Vec3f& dir, float value,
                        const SelectionSample* selection) {
    Learner& mine = learner();
    if (!merge_ && &mine != first_.load(std::memory_order_relaxed)) return;  // (planted bug)
    const int slot = int(pass & 1);
    // (the cell's box too: the spatial filter's width)
    float lo[3], size[3], lower[3], upper[3];
    const uint32_t cell = cell_box(p, lo, size, lower, upper);
    CellSums& sums = mine.cells[slot][cell];
    ++sums.count;
    if (!box_set_) {
        const float at[3] = {p.x, p.y, p.z};
        std::vector<uint64_t>& bins = mine.bins[slot];
        for (int a = 0; a < 3; ++a)
            if (std::isfinite(at[a])) ++bins[size_t(a) * kBoxBins + (ordered(at[a]) >> kBinShift)];
    }
    if (selection && selection->integrand > 0.0f) {
        const SelectionSample& s = *selection;
        const float used = s.fraction * s.guide_pdf + (1.0f - s.fraction) * s.lobe_pdf;
        for (int k = 0; k < kGuideFractionCount; ++k) {
            const float a = kGuideFractions[k];
            const float pk = a * s.guide_pdf + (1.0f - a) * s.lobe_pdf;
            // (a candidate that cannot draw the direction: the largest second moment)
            const float m = pk > 0.0f && used > 0.0f ? (s.integrand / pk) * (s.integrand / used)
                                                     : std::numeric_limits<float>::infinity();
            const uint64_t q = quantise(m);
            sums.low[k] += q;
            sums.high[k] += sums.low[k] < q ? 1u : 0u;  // (the carry)
        }
    }
    if (!(value > 0.0f)) return;  // (NaN too)

    // Over space, the stochastic box filter: the energy goes to the cell of p moved by up
    // to half its cell's size along each axis, the offsets a hash of the record (so a
    // record's cell depends on the record alone, not on the order or the thread; records
    // of the very same point and direction all move alike)
    uint32_t into = cell;
    if (filter_ && spatial_.size() > 1) {
        uint64_t h = bits_of(p.x) | (uint64_t(bits_of(p.y)) << 32);
        h = mix64(h ^ mix64(bits_of(p.z) | (uint64_t(bits_of(dir.x)) << 32)));
        h = mix64(h ^ (bits_of(dir.y) | (uint64_t(bits_of(dir.z)) << 32)));
        const float at[3] = {p.x, p.y, p.z};
        float m[3];
        bool inside = true;  // (then the descent would find `cell` again)
        for (int a = 0; a < 3; ++a) {
            const float u = float((h >> (21 * a)) & 0x1fffff) * 0x1.0p-21f;  // [0, 1)
            m[a] = at[a] + (u - 0.5f) * size[a];
            inside = inside && m[a] >= lower[a] && m[a] < upper[a];
        }
        if (!inside) into = guide_cell(view_, Vec3f(m[0], m[1], m[2]));
    }

    // The learning tree's leaf at the direction: unfiltered, the deposit's own
    float x, y;
    direction_to_square(dir, x, y);
    const uint32_t root = learning_roots_[into];
    double side = 1.0;
    {
        float lx = x, ly = y;
        for (uint32_t n = root;;) {
            const uint32_t qx = lx >= 0.5f ? 1u : 0u, qy = ly >= 0.5f ? 1u : 0u;
            const uint32_t k = qx + 2u * qy;
            side *= 0.5;
            const uint32_t child = learning_child_[size_t(n) * 4 + k];
            if (!child && !filter_) {
                if (const uint64_t q = quantise(value))
                    add_exact(learning_[slot][n].low[k], learning_[slot][n].high[k], q);
                return;
            }
            if (!child) break;
            n = child;
            lx = 2.0f * lx - float(qx), ly = 2.0f * ly - float(qy);
        }
    }
    // Over directions, the box filter: a square of the leaf's side centred on the direction
    // (across φ's seam, y, it wraps; past the poles, x, its part is dropped), each leaf it
    // overlaps given the energy of its share of the square
    Splat s{learning_[slot].get(),
            learning_child_.get(),
            std::max(0.0, x - 0.5 * side),
            std::min(1.0, x + 0.5 * side),
            0.0,
            0.0,
            double(value) / (side * side)};
    const double y0 = y - 0.5 * side, y1 = y + 0.5 * side;
    s.y0 = std::max(0.0, y0), s.y1 = std::min(1.0, y1);
    s.add_below(root);
    if (y0 < 0.0) s.y0 = y0 + 1.0, s.y1 = 1.0, s.add_below(root);
    if (y1 > 1.0) s.y0 = 0.0, s.y1 = y1 - 1.0, s.add_below(root);
}

void PathGuide::Splat::add_below(uint32_t root) const {
    uint32_t n = root;
    double ox = 0.0, oy = 0.0, w = 1.0;
    for (;;) {
        // The quadrant that holds the square's low corner; the square in it (as add()
        // reckons overlaps: a neighbour it only touches gets nothing), and not a leaf
        const double h = 0.5 * w;
        const uint32_t kx = x0 >= ox + h ? 1u : 0u, ky = y0 >= oy + h ? 1u : 0u;
        const double qx = ox + h * double(kx), qy = oy + h * double(ky);
        if (x1 > qx + h || y1 > qy + h) break;
        const uint32_t child = children[size_t(n) * 4 + kx + 2u * ky];
        if (!child) break;
        n = child, ox = qx, oy = qy, w = h;
    }
    add(n, ox, oy, w);
}

void PathGuide::Splat::add(uint32_t n, double ox, double oy, double w) const {
    const double h = 0.5 * w;
    for (uint32_t k = 0; k < 4; ++k) {
        const double qx = ox + h * double(k & 1u), qy = oy + h * double(k >> 1);
        const double a = std::min(x1, qx + h) - std::max(x0, qx);
        const double b = std::min(y1, qy + h) - std::max(y0, qy);
        if (!(a > 0.0 && b > 0.0)) continue;
        if (const uint32_t child = children[size_t(n) * 4 + k]) {
            add(child, qx, qy, h);
        } else if (const uint64_t q = quantise(density * a * b)) {
            add_exact(sums[n].low[k], sums[n].high[k], q);
        }
    }
}

uint32_t PathGuide::cell_box(const Vec3f& p, float lo[3], float size[3], float lower[3],
                             float upper[3]) const {
    for (int a = 0; a < 3; ++a) {
        lo[a] = lo_[a], size[a] = size_[a];
        lower[a] = -std::numeric_limits<float>::infinity();
        upper[a] = std::numeric_limits<float>::infinity();
    }
    const float at[3] = {p.x, p.y, p.z};
    uint32_t n = 0;
    while (spatial_[n].child > 0) {  // (guide_cell's descent, keeping the box)
        const uint32_t axis = spatial_[n].axis_or_cell;
        size[axis] *= 0.5f;
        const float mid = lo[axis] + size[axis];
        const bool above = at[axis] >= mid;
        if (above)
            lo[axis] = mid, lower[axis] = mid;
        else
            upper[axis] = mid;
        n = uint32_t(spatial_[n].child) + (above ? 1u : 0u);
    }
    return spatial_[n].axis_or_cell;
}

void PathGuide::train(int64_t spp_end) {
    const auto start = std::chrono::steady_clock::now();
    commit_slot(0), commit_slot(1);
    // A guide that has stopped learning keeps what it learnt: its iterations hold no records,
    // and trained on none its cells would sample the whole sphere uniformly
    if (!learning()) return;
    const int64_t spp_iteration = std::max<int64_t>(spp_end - last_end_, 1);
    last_end_ = spp_end;
    if (!box_set_) set_box();
    const std::vector<CellTrees> trees = trained_trees();
    std::vector<uint64_t> counts;
    const std::vector<float> fraction = chosen_fractions(counts);
    std::vector<const CellTrees*> cell_trees;  // the new cells' trees
    std::vector<float> cell_fractions;
    rebuild_space(trees, fraction, counts, spp_iteration, cell_trees, cell_fractions);
    install_cells(cell_trees, std::move(cell_fractions));
    ++trainings_;
    update_view();
    training_seconds_.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    trained_at_.push_back(spp_end);
}

// The box of the first iteration's vertices between the quantiles, from the bins' outer
// edges, a little larger (a unit box without any); vertices outside it fall in its border
// cells.
void PathGuide::set_box() {
    for (int a = 0; a < 3; ++a) {
        const uint64_t* bins = committed_bins_.data() + size_t(a) * kBoxBins;
        uint64_t total = 0;
        for (size_t b = 0; b < kBoxBins; ++b) total += bins[b];
        float lo = -0.5f, hi = 0.5f;
        if (total > 0) {
            const uint64_t skip = uint64_t(kBoxQuantile * double(total));
            size_t first = 0, last = kBoxBins - 1;
            for (uint64_t seen = 0; first < kBoxBins; ++first)
                if ((seen += bins[first]) > skip) break;
            for (uint64_t seen = 0; last > 0; --last)
                if ((seen += bins[last]) > skip) break;
            // (a bin's lowest and highest floats, past the infinities' and NaNs' bins)
            lo = from_ordered(uint32_t(first) << kBinShift);
            hi = from_ordered((uint32_t(last) << kBinShift) | ((1u << kBinShift) - 1));
            const float most = std::numeric_limits<float>::max() / 4;
            lo = std::clamp(lo, -most, most), hi = std::clamp(hi, -most, most);
            if (!(lo <= hi)) lo = -0.5f, hi = 0.5f;
        }
        const float pad = std::max(1e-2f * (hi - lo), 1e-4f * std::max(std::abs(lo), std::abs(hi)));
        lo_[a] = lo - pad - 1e-20f;
        size_[a] = (hi + pad + 1e-20f) - lo_[a];
    }
    box_set_ = true;
    committed_bins_ = {};
    std::lock_guard lock(learners_mutex_);
    for (const std::unique_ptr<Learner>& l : learners_)
        for (std::vector<uint64_t>& b : l->bins) b = {};
}

// Each cell's sampled tree (its quadrants' shares of the exact energies, a quadrant's sum
// over its subtree) and its next learning tree (subdivided where a quadrant holds much).
std::vector<PathGuide::CellTrees> PathGuide::trained_trees() const {
    const size_t cells = learning_roots_.size();
    std::vector<CellTrees> trees(cells);
    std::vector<U128> energy(learning_size_ * 4);
    for (size_t n = learning_size_; n-- > 0;)  // (children come after their parents)
        for (int q = 0; q < 4; ++q) {
            const uint32_t ch = learning_child_[n * 4 + size_t(q)];
            energy[n * 4 + size_t(q)] = ch ? energy[size_t(ch) * 4] + energy[size_t(ch) * 4 + 1] +
                                                 energy[size_t(ch) * 4 + 2] +
                                                 energy[size_t(ch) * 4 + 3]
                                           : committed_[n * 4 + size_t(q)];
        }
    const size_t end_of_last = learning_size_;
    for (size_t c = 0; c < cells; ++c) {
        const uint32_t root = learning_roots_[c];
        const uint32_t end = c + 1 < cells ? learning_roots_[c + 1] : uint32_t(end_of_last);
        const U128 total = energy[size_t(root) * 4] + energy[size_t(root) * 4 + 1] +
                           energy[size_t(root) * 4 + 2] + energy[size_t(root) * 4 + 3];
        const double inv = total > 0 ? 1.0 / double(total) : 0.0;
        std::vector<std::array<double, 4>> share(end - root);
        std::vector<std::array<uint32_t, 4>> children(end - root);
        CellTrees& t = trees[c];
        t.sampled.resize(end - root);
        for (uint32_t n = root; n < end; ++n)
            for (int q = 0; q < 4; ++q) {
                const double s = double(energy[size_t(n) * 4 + size_t(q)]) * inv;
                const uint32_t ch = learning_child_[size_t(n) * 4 + size_t(q)];
                share[n - root][size_t(q)] = s;
                children[n - root][size_t(q)] = ch ? ch - root : 0u;
                t.sampled[n - root].energy[q] = float(s);
                t.sampled[n - root].child[q] = ch ? ch - root : 0u;
            }
        if (total > 0)
            subdivide(t.learning, &share, &children, 0, 1.0, 1, kGuideSubdivide, kGuideMaxDepth);
        else  // (no light came back: the cell keeps its learning tree's shape)
            for (uint32_t n = root; n < end; ++n) {
                Shape::Node s;
                for (int q = 0; q < 4; ++q) s.child[q] = children[n - root][size_t(q)];
                t.learning.nodes.push_back(s);
            }
    }
    return trees;
}

// Each cell's share α: the candidate of least second moment (a cell without records of it
// keeps its own); `counts` gets each cell's records, which the guide's count takes.
std::vector<float> PathGuide::chosen_fractions(std::vector<uint64_t>& counts) {
    const size_t cells = learning_roots_.size();
    std::vector<float> fraction(cells);
    counts.assign(cells, 0);
    for (size_t c = 0; c < cells; ++c) {
        fraction[c] = fractions_[c];
        counts[c] = committed_cells_[c].count;
        records_ += counts[c];
        const auto moment = [&](int k) { return committed_cells_[c].moment[k]; };
        int best = -1;
        for (int k = 0; k < kGuideFractionCount; ++k)
            if (moment(k) > 0 && (best < 0 || moment(k) < moment(best))) best = k;
        if (best >= 0) fraction[c] = kGuideFractions[best];
    }
    return fraction;
}

// The tree over space again, cells cut where they took many vertices (over a threshold that
// grows with the iteration's paths): each new cell's trees and share, in the cells' order.
void PathGuide::rebuild_space(const std::vector<CellTrees>& trees,
                              const std::vector<float>& fraction,
                              const std::vector<uint64_t>& counts, int64_t spp_iteration,
                              std::vector<const CellTrees*>& cell_trees,
                              std::vector<float>& cell_fractions) {
    const size_t cells = trees.size();
    const double threshold = kGuideSpatialThreshold * std::sqrt(double(spp_iteration) / 4.0);
    std::vector<GuideSpatialNode> spatial;
    uint64_t nodes = 0;
    uint32_t cells_total = uint32_t(cells);
    for (const CellTrees& t : trees) nodes += t.sampled.size() + t.learning.nodes.size();
    struct Box {
        float lo[3], size[3];
    };
    // Node `at` becomes the cut of `box` across `axis`: its halves' first slot and boxes
    struct Halves {
        uint32_t child;
        Box below, above;
    };
    const auto cut = [&](uint32_t at, Box box, uint32_t axis) {
        const uint32_t child = uint32_t(spatial.size());
        spatial.resize(spatial.size() + 2);
        spatial[at] = {int32_t(child), axis};
        box.size[axis] *= 0.5f;
        Box above = box;
        above.lo[axis] += box.size[axis];
        return Halves{child, box, above};
    };
    // (old node `n` with box b into new slot `slot`)
    const auto rebuild = [&](auto&& self, uint32_t n, Box b, uint32_t slot) -> void {
        const GuideSpatialNode& old = spatial_[n];
        if (old.child > 0) {
            const Halves h = cut(slot, b, old.axis_or_cell);
            self(self, uint32_t(old.child), h.below, h.child);
            self(self, uint32_t(old.child) + 1, h.above, h.child + 1);
            return;
        }
        // A cell: cut while its halves would hold more than the threshold, within the
        // bounds on cells and nodes (each cut adds a cell and a copy of its trees)
        const CellTrees& t = trees[old.axis_or_cell];
        const uint64_t per_copy = t.sampled.size() + t.learning.nodes.size();
        const auto split = [&](auto&& again, Box box, double count, uint32_t at,
                               int depth) -> void {
            if (count > threshold && depth < 48 && cells_total < kGuideMaxCells &&
                nodes + per_copy <= kGuideMaxNodes) {
                ++cells_total;
                nodes += per_copy;
                uint32_t axis = 0;  // (the longest side)
                for (uint32_t a = 1; a < 3; ++a)
                    if (box.size[a] > box.size[axis]) axis = a;
                const Halves h = cut(at, box, axis);
                again(again, h.below, count * 0.5, h.child, depth + 1);
                again(again, h.above, count * 0.5, h.child + 1, depth + 1);
                return;
            }
            spatial[at] = {0, uint32_t(cell_trees.size())};
            cell_trees.push_back(&t);
            cell_fractions.push_back(fraction[old.axis_or_cell]);
        };
        split(split, b, double(counts[old.axis_or_cell]), slot, 0);
    };
    spatial.resize(1);
    Box whole;
    for (int a = 0; a < 3; ++a) whole.lo[a] = lo_[a], whole.size[a] = size_[a];
    rebuild(rebuild, 0, whole, 0);
    spatial_ = std::move(spatial);
}

// The cells' trees, in the cells' order: the sampled ones into one array, the learning ones
// allocated.
void PathGuide::install_cells(const std::vector<const CellTrees*>& cell_trees,
                              std::vector<float>&& cell_fractions) {
    directions_.clear();
    roots_.assign(cell_trees.size(), 0);
    std::vector<Shape> learning;
    learning.reserve(cell_trees.size());
    for (size_t c = 0; c < cell_trees.size(); ++c) {
        const CellTrees& t = *cell_trees[c];
        const uint32_t base = uint32_t(directions_.size());
        roots_[c] = base;
        for (GuideDirectionNode n : t.sampled) {
            for (uint32_t& ch : n.child)
                if (ch) ch += base;
            directions_.push_back(n);
        }
        learning.push_back(t.learning);
    }
    fractions_ = std::move(cell_fractions);
    allocate_learning(learning);
}

// ---- Saved states and ranks' sums ---------------------------------------------------------

namespace {

constexpr char kStateMagic[16] = "cierzo guide 2";  // (2: filtered deposits)
constexpr char kSumsMagic[16] = "cierzo sums 1";

struct Out {
    std::vector<char> bytes;
    template <typename T>
    void put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        const size_t at = bytes.size();
        bytes.resize(at + sizeof(T));
        std::memcpy(bytes.data() + at, &v, sizeof(T));
    }
    template <typename T>
    void array(const T* data, size_t n) {
        static_assert(std::is_trivially_copyable_v<T>);
        put(uint64_t(n));
        if (n == 0) return;
        const size_t at = bytes.size();
        bytes.resize(at + n * sizeof(T));
        std::memcpy(bytes.data() + at, data, n * sizeof(T));
    }
};

struct In {
    const std::vector<char>& bytes;
    size_t at = 0;
    template <typename T>
    T get() {
        if (sizeof(T) > bytes.size() - at) throw GuideStateError("truncated");
        T v;
        std::memcpy(&v, bytes.data() + at, sizeof(T));
        at += sizeof(T);
        return v;
    }
    // An array of at most `most` entries
    template <typename T>
    std::vector<T> array(uint64_t most, const char* what) {
        const uint64_t n = get<uint64_t>();
        if (n > most)
            throw GuideStateError(std::string(what) + ": " + std::to_string(n) +
                                  " entries, at most " + std::to_string(most) + " possible");
        if (n > (bytes.size() - at) / sizeof(T)) throw GuideStateError("truncated");
        std::vector<T> v(n);
        if (n) std::memcpy(v.data(), bytes.data() + at, n * sizeof(T));
        at += n * sizeof(T);
        return v;
    }
    void magic(const char (&m)[16], const char* what) {
        char got[16];
        for (char& c : got) c = get<char>();
        if (std::memcmp(got, m, 16) != 0)
            throw GuideStateError(std::string("not ") + what + " of this cierzo");
    }
    void end() const {
        if (at != bytes.size()) throw GuideStateError("longer than its contents");
    }
};

// FNV-1a over the learning trees' shape: ranks' sums are added only onto the same trees
uint64_t shape_hash(const uint32_t* child, size_t n, const std::vector<uint32_t>& roots) {
    uint64_t h = 1469598103934665603ull;
    const auto mix = [&](uint32_t v) { h = (h ^ v) * 1099511628211ull; };
    for (size_t i = 0; i < n; ++i) mix(child[i]);
    for (uint32_t r : roots) mix(r);
    return h;
}

}  // namespace

std::vector<char> PathGuide::sums() const {
    Out o;
    for (char c : kSumsMagic) o.put(c);
    o.put(shape_hash(learning_child_.get(), learning_size_ * 4, learning_roots_));
    o.array(committed_bins_.data(), committed_bins_.size());
    o.array(committed_.data(), committed_.size());
    o.array(committed_cells_.data(), committed_cells_.size());
    return std::move(o.bytes);
}

void PathGuide::add_sums(const std::vector<char>& bytes) {
    In in{bytes};
    in.magic(kSumsMagic, "a guide's sums");
    if (in.get<uint64_t>() !=
        shape_hash(learning_child_.get(), learning_size_ * 4, learning_roots_))
        throw GuideStateError("sums of other learning trees");
    const std::vector<uint64_t> bins = in.array<uint64_t>(committed_bins_.size(), "box bins");
    const std::vector<U128> nodes = in.array<U128>(committed_.size(), "learning sums");
    const std::vector<CellTotals> cells = in.array<CellTotals>(committed_cells_.size(), "cells");
    in.end();
    if (nodes.size() != committed_.size() || cells.size() != committed_cells_.size() ||
        bins.size() != committed_bins_.size())
        throw GuideStateError("sums of other learning trees");
    for (size_t i = 0; i < nodes.size(); ++i) committed_[i] += nodes[i];
    for (size_t c = 0; c < cells.size(); ++c) {
        committed_cells_[c].count += cells[c].count;
        for (int k = 0; k < kGuideFractionCount; ++k)
            committed_cells_[c].moment[k] += cells[c].moment[k];
    }
    for (size_t i = 0; i < bins.size(); ++i) committed_bins_[i] += bins[i];
}

std::vector<char> PathGuide::save() const {
    Out o;
    for (char c : kStateMagic) o.put(c);
    o.put(int32_t(trainings_)), o.put(last_end_), o.put(uint8_t(box_set_)), o.put(records_);
    for (int a = 0; a < 3; ++a) o.put(lo_[a]), o.put(size_[a]);
    o.array(trained_at_.data(), trained_at_.size());
    o.array(training_seconds_.data(), training_seconds_.size());
    o.array(spatial_.data(), spatial_.size());
    o.array(directions_.data(), directions_.size());
    o.array(roots_.data(), roots_.size());
    o.array(fractions_.data(), fractions_.size());
    o.array(learning_roots_.data(), learning_roots_.size());
    o.array(learning_child_.get(), learning_size_ * 4);
    std::vector<char> sums = this->sums();
    o.array(sums.data(), sums.size());
    return std::move(o.bytes);
}

void PathGuide::restore(const std::vector<char>& bytes, bool with_sums) {
    In in{bytes};
    in.magic(kStateMagic, "a path guide's state");
    const int32_t trainings = in.get<int32_t>();
    const int64_t last_end = in.get<int64_t>();
    const uint8_t box_set = in.get<uint8_t>();
    const uint64_t records = in.get<uint64_t>();
    float lo[3], size[3];
    for (int a = 0; a < 3; ++a) lo[a] = in.get<float>(), size[a] = in.get<float>();
    const uint64_t most_trainings = 64;
    auto trained_at = in.array<int64_t>(most_trainings, "trainings");
    auto seconds = in.array<double>(most_trainings, "training times");
    // (a cell's cut adds two nodes)
    auto spatial = in.array<GuideSpatialNode>(2 * uint64_t(kGuideMaxCells), "spatial nodes");
    auto directions = in.array<GuideDirectionNode>(kGuideMaxNodes + 1, "quadtree nodes");
    auto roots = in.array<uint32_t>(kGuideMaxCells, "cells");
    auto fractions = in.array<float>(kGuideMaxCells, "cells' shares");
    auto learning_roots = in.array<uint32_t>(kGuideMaxCells, "learning trees");
    auto child = in.array<uint32_t>(4 * uint64_t(kGuideMaxNodes), "learning nodes");
    const std::vector<char> sums = in.array<char>(bytes.size(), "sums");
    in.end();

    // Every size and index, so that no lookup can leave its array or loop
    const auto fail = [](const std::string& why) { throw GuideStateError(why); };
    const size_t cells = roots.size();
    if (trainings < 0 || size_t(trainings) != trained_at.size() ||
        seconds.size() != trained_at.size() || last_end < 0 ||
        (trainings > 0 && last_end != trained_at.back()) || (trainings > 0 && !box_set))
        fail("inconsistent trainings");
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(lo[a]) || !(size[a] > 0.0f) || !std::isfinite(size[a]))
            fail("a box that is not finite");
    if (cells == 0 || fractions.size() != cells || learning_roots.size() != cells ||
        spatial.empty() || directions.empty() || child.empty() || child.size() % 4 != 0)
        fail("inconsistent cell counts");
    std::vector<uint8_t> seen(cells, 0);
    for (size_t n = 0; n < spatial.size(); ++n) {
        const GuideSpatialNode& s = spatial[n];
        if (s.child > 0) {
            if (size_t(s.child) <= n || size_t(s.child) + 1 >= spatial.size() || s.axis_or_cell > 2)
                fail("a spatial node out of range");
        } else if (s.child < 0 || s.axis_or_cell >= cells || seen[s.axis_or_cell]++) {
            fail("a spatial leaf out of range");
        }
    }
    for (size_t n = 0; n < directions.size(); ++n)
        for (int q = 0; q < 4; ++q) {
            const uint32_t ch = directions[n].child[q];
            const float e = directions[n].energy[q];
            if ((ch != 0 && (ch <= n || ch >= directions.size())) || !(e >= 0.0f) ||
                !std::isfinite(e))
                fail("a quadtree node out of range");
        }
    const size_t nodes = child.size() / 4;
    for (size_t c = 0; c < cells; ++c) {
        if (roots[c] >= directions.size() || learning_roots[c] >= nodes ||
            (c == 0 ? learning_roots[c] != 0 : learning_roots[c] <= learning_roots[c - 1]))
            fail("a cell's tree out of range");
        bool known = false;
        for (float f : kGuideFractions) known |= f == fractions[c];
        if (!known) fail("a cell's share that is not one of the candidates");
    }
    for (size_t n = 0; n < nodes; ++n)
        for (int q = 0; q < 4; ++q) {
            const uint32_t ch = child[n * 4 + size_t(q)];
            if (ch != 0 && (ch <= n || ch >= nodes)) fail("a learning node out of range");
        }

    trainings_ = trainings, last_end_ = last_end, box_set_ = box_set != 0, records_ = records;
    for (int a = 0; a < 3; ++a) lo_[a] = lo[a], size_[a] = size[a];
    trained_at_ = std::move(trained_at), training_seconds_ = std::move(seconds);
    spatial_ = std::move(spatial), directions_ = std::move(directions);
    roots_ = std::move(roots), fractions_ = std::move(fractions);
    learning_roots_ = std::move(learning_roots);
    learning_child_ = std::make_unique<uint32_t[]>(child.size());
    std::memcpy(learning_child_.get(), child.data(), child.size() * 4);
    resize_sums(nodes, cells);
    committed_bins_.assign(box_set_ ? 0 : 3 * kBoxBins, 0);
    {
        std::lock_guard lock(learners_mutex_);
        for (const std::unique_ptr<Learner>& l : learners_)
            for (std::vector<uint64_t>& b : l->bins) b.assign(committed_bins_.size(), 0);
    }
    add_sums(sums);  // (checked in any case: they must fit the trees)
    if (!with_sums) {
        resize_sums(nodes, cells);
        std::fill(committed_bins_.begin(), committed_bins_.end(), 0);
    }
    update_view();
}

std::vector<char> PathGuide::merge_states(const std::vector<std::vector<char>>& states) {
    if (states.empty()) return {};
    PathGuide total;
    total.restore(states[0]);
    for (size_t i = 1; i < states.size(); ++i) {
        PathGuide g;
        g.restore(states[i]);
        total.add_sums(g.sums());
    }
    return total.save();
}

GuideStats PathGuide::stats() const {
    std::lock_guard lock(learners_mutex_);
    GuideStats s;
    s.cells = uint32_t(roots_.size());
    s.nodes = directions_.size();
    s.learning_nodes = learning_size_;
    s.bytes = directions_.capacity() * sizeof(GuideDirectionNode) +
              learning_size_ * (2 * sizeof(LearnNode) + 4 * sizeof(U128) + 16) +
              spatial_.capacity() * sizeof(GuideSpatialNode) + roots_.capacity() * 4 +
              learning_roots_.capacity() * 4 + fractions_.capacity() * 4 +
              (2 * learners_.size() * sizeof(CellSums) + sizeof(CellTotals)) * roots_.size() +
              committed_bins_.capacity() * 8;  // (the box's histograms: first iteration)
    for (const std::unique_ptr<Learner>& l : learners_)
        for (const std::vector<uint64_t>& b : l->bins) s.bytes += b.capacity() * 8;
    s.cells_by_fraction.assign(kGuideFractionCount, 0);
    for (float f : fractions_)
        for (int k = 0; k < kGuideFractionCount; ++k)
            if (f == kGuideFractions[k]) ++s.cells_by_fraction[size_t(k)];
    s.learning = learning();
    s.records = records_;  // (and those since the last training)
    for (const CellTotals& c : committed_cells_) s.records += c.count;
    for (const std::unique_ptr<Learner>& l : learners_)
        for (const std::vector<CellSums>& slot : l->cells)
            for (const CellSums& c : slot) s.records += c.count;
    s.training_seconds = training_seconds_;
    s.trained_at = trained_at_;
    return s;
}

}  // namespace cierzo
