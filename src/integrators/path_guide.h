// Path guiding's learning side: the SD-tree (kernels/guiding.h) that nee's and mis's camera
// paths sample from, learned from the light those paths carried back in earlier passes.
//
// Training in iterations. An iteration is the passes between two trainings; the trainings
// fall before the passes that start at a power of two paths per pixel (1, 2, 4, 8, ...), so
// each iteration has as many paths as all before it (Müller et al. 2017's doubling). While an
// iteration runs, the guide sampled is fixed, and every Phong vertex of a camera path
// deposits what came back along its direction, L/p (the luminance of the light the rest of
// the path gathered, divided by the throughput from there and by the density the direction
// was drawn with), into a second quadtree of its cell (the learning tree), and counts itself
// in its cell. The deposit is filtered, as in Müller's "Practical Path Guiding in
// Production" (2019): over space, it goes to the cell of its point moved by a pseudo-random
// offset of up to half its own cell's size per axis (a hash of the record: a stochastic box
// filter that stays a function of the record); over directions, it spreads over the learning
// tree's leaves under a square the side of its own leaf centred on it (a box filter). A
// direction next to one where much light was seen then keeps some density, where nearest-
// leaf deposits left a few sampled directions carrying all of a rare path's light. At the
// training:
//   - each cell's learning tree, with its energies, becomes the cell's sampled tree;
//   - its next learning tree subdivides every quadrant holding more than kGuideSubdivide of
//     the cell's energy, to kGuideMaxDepth levels, and merges the rest;
//   - each cell's share α of guided directions (kernels/guiding.h, kGuideFractions) becomes
//     the candidate whose second moment, estimated from the iteration's diffuse records
//     (SelectionSample), is least;
//   - a cell with more than kGuideSpatialThreshold·√(paths per pixel of the iteration / 4)
//     vertices is cut in half across its box's longest side, again while its halves would
//     still hold more (each half starting with a copy of its quadtrees).
//
// Bit-reproducible. Deposits are added as integers (each L/p in fixed point, 2^-32 to 2^30,
// into 128-bit sums kept as two 64-bit atomics with the carry), so the sums are exact and
// the same whatever the order in which threads add them; a path's deposits depend only on
// the guide of its pass; the training is one thread's deterministic arithmetic on those
// sums. So an image is the same for any number of threads. Deposits go to their pass's
// slot (pass mod 2: the units of the pass after the one in progress may be rendered
// early), which joins the iteration's exact sums when the pass is whole (commit_pass).
// Those sums, with the trees, are what a checkpoint keeps (save, restore: a resumed render
// goes on with the very numbers) and what ranks add up before each training (sums,
// add_sums: every rank then trains the same trees from the same integers).
//
// Memory is bounded: at most kGuideMaxCells cells and kGuideMaxNodes quadtree nodes, which
// stop the subdivisions where they would be exceeded (stats(): what it uses).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/guide_record.h"
#include "integrators/guide_stats.h"
#include "kernels/guiding.h"
#include "kernels/vec3.h"

namespace cierzo {

__extension__ typedef unsigned __int128 GuideSum;  // an exact sum of deposits

inline constexpr double kGuideSubdivide = 0.01;          // ρ: a quadrant's share to subdivide
inline constexpr int kGuideMaxDepth = 20;                // quadtree levels
inline constexpr double kGuideSpatialThreshold = 12000;  // c: vertices per cell, as above
inline constexpr uint32_t kGuideMaxCells = 1u << 14;
// The records the trainings take before the guide stops learning: the passes after the
// training that reaches them sample its last guide and record nothing (their records cost
// a wavefront path about as much as the path itself; docs/guiding.md)
inline constexpr uint64_t kGuideLearnRecords = uint64_t(1) << 25;
inline constexpr uint32_t kGuideMaxNodes = 1u << 20;

// A saved state or a rank's sums that cannot be read (what is wrong with it); the caller
// names the file or the rank.
struct GuideStateError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

class PathGuide {
public:
    // (`merge`: always true; false learns from the records of the first thread that
    // deposits alone, not the whole pass merged: a planted bug for the tests. `filter`:
    // the deposits' filters over space and directions, as above; false puts each in its
    // own cell and quadrant, for the tests and measurements. `first_fraction`: every cell's
    // share α until its records choose one; the tests' small renders take ½ to sample their
    // guides from the first training on.
    // `learn_records`: kGuideLearnRecords, or fewer for the tests.)
    explicit PathGuide(bool merge = true, bool filter = true,
                       float first_fraction = kGuideFirstFraction,
                       uint64_t learn_records = kGuideLearnRecords);
    PathGuide(const PathGuide&) = delete;
    PathGuide& operator=(const PathGuide&) = delete;
    ~PathGuide();

    // Whether a training comes before the pass that starts at `spp` paths per pixel.
    static bool trains_before(int64_t spp) { return spp > 0 && (spp & (spp - 1)) == 0; }

    // What the paths sample from: null before the first training.
    const GuideView* view() const { return trainings_ > 0 ? &view_ : nullptr; }
    // Whether the paths record for it: until its trainings have taken `learn_records`
    // records (the same for the whole iteration, and kept by save)
    bool learning() const { return records_ < learn_records_; }

    // What a diffuse vertex's record tells of the guide's share α: the estimate of the
    // integrand at its direction, f·cos θ·L (luminance), and the densities of the guide and
    // the lobe there with the share it was drawn with. For each candidate α' the record adds
    // (f·cos θ·L)² / (p_α'·p_used) to the cell's estimate of that candidate's second moment.
    struct SelectionSample {
        float integrand = 0.0f;
        float guide_pdf = 0.0f, lobe_pdf = 0.0f;
        float fraction = 0.0f;
    };

    // One vertex's record, of a path of pass `pass`: the direction `dir` leaving point p,
    // and what came back along it divided by its density (L/p, before the quantisation);
    // `selection` where the vertex was diffuse with a guide to sample. Thread-safe.
    void deposit(int32_t pass, const Vec3f& p, const Vec3f& dir, float value,
                 const SelectionSample* selection = nullptr);

    // A camera path's record of one vertex (guide_record.h), when the path has ended: it
    // deposits L/p, L the luminance of gathered/throughput (0 where the throughput is), p
    // its density; with its selection sample where it has one. Thread-safe.
    void deposit(int32_t pass, const GuideRecord& r);

    // Pass `pass` is whole (no path of it is being rendered): its deposits join the
    // iteration's sums. Not while a path of pass + 2 is rendered (the same slot).
    void commit_pass(int32_t pass);

    // Ends the iteration after the passes up to `spp_end` paths per pixel (no paths may be
    // rendered meanwhile, and none of a later pass has been): every deposit joins the
    // iteration's sums, and the learnt trees become the sampled ones. Once the guide has
    // stopped learning, the trees and shares stay as they are.
    void train(int64_t spp_end);
    // The paths per pixel of the last training (0: none yet).
    int64_t trained_through() const { return last_end_; }

    // The whole state after the committed passes (the trees sampled and learning, and the
    // iteration's exact sums): restored, it goes on as this guide would. restore() takes a
    // fresh guide; with `sums` false it leaves the iteration's sums at zero (the other ranks
    // of a resumed render: one rank holds them). It checks every size and index and throws
    // GuideStateError for a state that is malformed.
    std::vector<char> save() const;
    void restore(const std::vector<char>& state, bool sums = true);
    // The committed passes' exact sums (a rank's, for the others before a training), and
    // adding another guide's: a guide of the same trees (GuideStateError otherwise).
    std::vector<char> sums() const;
    void add_sums(const std::vector<char>& sums);
    // The state of ranks' guides of the same trees (save's, each with its rank's sums) as
    // one guide with all their sums: a checkpoint's under MPI.
    static std::vector<char> merge_states(const std::vector<std::vector<char>>& states);

    GuideStats stats() const;

    struct Shape;  // a quadtree's shape, nodes and children, as training builds it

private:
    struct LearnNode;  // a learning quadtree node: its quadrants' exact sums
    struct CellTrees;  // one cell's sampled tree and next learning tree

    // A deposit's square over directions [x0, x1) × [y0, y1), spread over the leaves of a
    // learning tree, each given density × its overlap
    struct Splat {
        LearnNode* sums;
        const uint32_t* children;
        double x0, x1, y0, y1, density;
        void add(uint32_t node, double ox, double oy, double width) const;
        // add() from the deepest node below `root` whose square holds [x0, x1] × [y0, y1]
        // (the same leaves, the same amounts: a descent from the root reaches no others)
        void add_below(uint32_t root) const;
    };
    // The cell of p, and its box; and the bounds its descent compared p with: any point q
    // with lower ≤ q < upper on every axis is in the same cell
    uint32_t cell_box(const Vec3f& p, float lo[3], float size[3], float lower[3],
                      float upper[3]) const;
    // The steps of train()
    void set_box();
    std::vector<CellTrees> trained_trees() const;
    std::vector<float> chosen_fractions(std::vector<uint64_t>& counts);
    void rebuild_space(const std::vector<CellTrees>& trees, const std::vector<float>& fraction,
                       const std::vector<uint64_t>& counts, int64_t spp_iteration,
                       std::vector<const CellTrees*>& cell_trees,
                       std::vector<float>& cell_fractions);
    void install_cells(const std::vector<const CellTrees*>& cell_trees,
                       std::vector<float>&& cell_fractions);
    void update_view();
    void resize_sums(size_t nodes, size_t cells);  // zeroed
    void allocate_learning(const std::vector<Shape>& trees);

    std::vector<GuideSpatialNode> spatial_{GuideSpatialNode{}};
    std::vector<GuideDirectionNode> directions_;  // every cell's sampled tree
    std::vector<uint32_t> roots_;                 // per cell
    std::vector<float> fractions_;                // per cell: α
    // The learning trees: per pass slot, their quadrants' sums (atomic: deposits); the
    // committed passes' (U128, four a node)
    std::unique_ptr<LearnNode[]> learning_[2];
    std::vector<GuideSum> committed_;
    std::unique_ptr<uint32_t[]> learning_child_;  // 4 per node: its quadrants' nodes, or 0
    size_t learning_size_ = 0;
    std::vector<uint32_t> learning_roots_;  // per cell
    // Each render thread's sums per cell and pass slot (its vertices, and for each candidate
    // α the second moment's estimate, low and high words), added up when a pass is
    // committed: the cells' sums are touched by every record, and shared ones would have
    // every thread wait on their lines
    struct CellSums {
        uint64_t count = 0;
        uint64_t low[kGuideFractionCount] = {}, high[kGuideFractionCount] = {};
    };
    struct Learner {
        std::vector<CellSums> cells[2];
        std::vector<uint64_t> bins[2];  // the first iteration's: kBoxBins per axis
    };
    struct CellTotals {  // the committed passes'
        uint64_t count = 0;
        GuideSum moment[kGuideFractionCount] = {};
    };
    std::vector<CellTotals> committed_cells_;
    Learner& learner();  // this thread's
    void commit_slot(int slot);
    const uint64_t serial_;  // (which guide a thread's cached learner is of)
    const bool merge_;
    const bool filter_;
    const uint64_t learn_records_;
    mutable std::mutex learners_mutex_;  // (learners_ grows as threads first deposit)
    std::vector<std::unique_ptr<Learner>> learners_;
    std::atomic<Learner*> first_{nullptr};
    uint64_t records_ = 0;
    // The box of the tree over space, from the first iteration's vertices: each axis's
    // histogram (kBoxBins bins of the coordinates' float order) of the committed passes
    std::vector<uint64_t> committed_bins_;
    bool box_set_ = false;
    float lo_[3] = {0.0f, 0.0f, 0.0f}, size_[3] = {1.0f, 1.0f, 1.0f};
    int64_t last_end_ = 0;
    int trainings_ = 0;
    std::vector<double> training_seconds_;
    std::vector<int64_t> trained_at_;
    GuideView view_;
};

}  // namespace cierzo
