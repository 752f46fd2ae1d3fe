// Path guiding: the SD-tree's sampling against its density (chi-square), the density's
// integral, degenerate cells, and the learning's independence of the records' order and of
// threads (src/integrators/path_guide.h, kernels/guiding.h).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include <unistd.h>

#include "core/error.h"
#include "integrators/checkpoint.h"
#include "integrators/path_guide.h"
#include "integrators/registry.h"
#include "integrators/render.h"
#include "scene/estimator_options.h"
#include "support/analytic_scenes.h"
#include "support/emulator.h"
#include "support/report_scene.h"
#include "support/removed_at_exit.h"
#include "support/render_variants.h"
#include "support/statistics.h"

namespace cierzo {
namespace {

struct Record {
    Vec3f p, dir;
    float value;
};

Vec3f uniform_direction(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    return square_to_direction(u(rng), u(rng));
}

// Records at points in the unit cube whose light comes mostly from a cone around `peak`,
// the rest from everywhere, each with the value L/p of a uniform sampler
std::vector<Record> lobe_records(size_t n, uint32_t seed, const Vec3f& peak) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Record> out;
    for (size_t i = 0; i < n; ++i) {
        const Vec3f p(u(rng), u(rng), u(rng));
        Vec3f d = uniform_direction(rng);
        if (u(rng) < 0.7f) d = normalize(peak + d * 0.25f);
        out.push_back({p, d, float(4.0 * kPi) * (0.5f + u(rng))});
    }
    return out;
}

// The guide's probability of the square region [x0, x1) × [y0, y1) (in the node's own
// coordinates) under node n, exactly: each quadrant's share times its overlap
double mass(const GuideView& g, uint32_t n, double x0, double y0, double x1, double y1) {
    const GuideDirectionNode& node = g.directions[n];
    const double total = double(node.energy[0]) + node.energy[1] + node.energy[2] + node.energy[3];
    if (!(total > 0.0)) return (x1 - x0) * (y1 - y0);
    double m = 0.0;
    for (int q = 0; q < 4; ++q) {
        const double qx = 0.5 * (q & 1), qy = 0.5 * (q >> 1);
        const double a0 = std::max(x0, qx), a1 = std::min(x1, qx + 0.5);
        const double b0 = std::max(y0, qy), b1 = std::min(y1, qy + 0.5);
        if (a0 >= a1 || b0 >= b1) continue;
        const double share = node.energy[q] / total;
        if (node.child[q])
            m += share *
                 mass(g, node.child[q], 2 * (a0 - qx), 2 * (b0 - qy), 2 * (a1 - qx), 2 * (b1 - qy));
        else
            m += share * (a1 - a0) * (b1 - b0) * 4.0;
    }
    return m;
}

// A guide trained twice on the records of a lobe (the second time on its refined trees)
void train_on(PathGuide& guide, const std::vector<Record>& records, int64_t spp) {
    for (const Record& r : records) guide.deposit(0, r.p, r.dir, r.value);
    guide.train(spp);
}

TEST(Guiding, SamplingFollowsTheDensityItReports) {
    PathGuide guide;
    const Vec3f peak = normalize(Vec3f(0.3f, 0.5f, 0.8f));
    train_on(guide, lobe_records(200000, 1, peak), 1);
    train_on(guide, lobe_records(400000, 2, peak), 2);
    const GuideView* g = guide.view();
    ASSERT_NE(g, nullptr);
    const uint32_t root = g->roots[guide_cell(*g, Vec3f(0.5f, 0.5f, 0.5f))];
    // (the tree learnt the lobe: deeper than its first three levels)
    EXPECT_GT(guide.stats().nodes, 21u);

    constexpr int kBins = 32;
    std::vector<double> observed(kBins * kBins, 0.0), expected(kBins * kBins, 0.0);
    const int n = 400000;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int mismatched = 0;
    for (int i = 0; i < n; ++i) {
        float pdf;
        const Vec3f d = guide_sample(*g, root, u(rng), u(rng), pdf);
        ASSERT_TRUE(std::isfinite(pdf) && pdf > 0.0f);
        ASSERT_NEAR(length(d), 1.0f, 1e-5f);
        const float again = guide_pdf(*g, root, d);
        if (std::abs(again - pdf) > 1e-3f * pdf) ++mismatched;  // (a quadrant's edge)
        float x, y;
        direction_to_square(d, x, y);
        observed[size_t(std::min(int(y * kBins), kBins - 1) * kBins +
                        std::min(int(x * kBins), kBins - 1))] += 1.0;
    }
    EXPECT_LT(mismatched, n / 1000) << "the density sampled is not the density evaluated";
    for (int by = 0; by < kBins; ++by)
        for (int bx = 0; bx < kBins; ++bx)
            expected[size_t(by * kBins + bx)] =
                n * mass(*g, root, double(bx) / kBins, double(by) / kBins, double(bx + 1) / kBins,
                         double(by + 1) / kBins);
    const auto [stat, dof] = test::chi_square(observed, expected);
    EXPECT_LT(stat, test::chi_square_critical(dof)) << "dof " << dof;
}

TEST(Guiding, DensityIntegratesToOneOverTheSphere) {
    PathGuide guide;
    const Vec3f peak = normalize(Vec3f(-0.2f, 0.1f, -0.9f));
    train_on(guide, lobe_records(100000, 3, peak), 1);
    train_on(guide, lobe_records(200000, 4, peak), 2);
    const GuideView* g = guide.view();
    ASSERT_NE(g, nullptr);
    for (uint32_t cell = 0; cell < std::min(guide.stats().cells, 4u); ++cell) {
        const uint32_t root = g->roots[cell];
        // (the map is equal-area: a grid of the square is a grid of equal solid angles)
        constexpr int kGrid = 512;
        double sum = 0.0;
        for (int y = 0; y < kGrid; ++y)
            for (int x = 0; x < kGrid; ++x)
                sum += guide_pdf(*g, root,
                                 square_to_direction((x + 0.5f) / kGrid, (y + 0.5f) / kGrid));
        EXPECT_NEAR(sum * 4.0 * kPi / (double(kGrid) * kGrid), 1.0, 5e-3) << "cell " << cell;
        EXPECT_NEAR(mass(*g, root, 0, 0, 1, 1), 1.0, 1e-5) << "cell " << cell;
    }
}

// A cell's sampling at the extremes of its numbers gives unit directions and finite,
// positive densities
void expect_sane(const GuideView& g, uint32_t root) {
    const float us[] = {0.0f, 1e-7f, 0.5f, 0.999f, 0x1.fffffep-1f};
    for (float u1 : us)
        for (float u2 : us) {
            float pdf;
            const Vec3f d = guide_sample(g, root, u1, u2, pdf);
            EXPECT_TRUE(std::isfinite(pdf) && pdf > 0.0f) << u1 << " " << u2;
            EXPECT_NEAR(length(d), 1.0f, 1e-5f);
            const float again = guide_pdf(g, root, d);
            EXPECT_TRUE(std::isfinite(again) && again >= 0.0f);
        }
}

TEST(Guiding, DegenerateCellsGiveNoNaN) {
    {  // no records at all: uniform
        PathGuide guide;
        EXPECT_EQ(guide.view(), nullptr);  // (nothing to sample before the first training)
        guide.train(1);
        const GuideView* g = guide.view();
        ASSERT_NE(g, nullptr);
        EXPECT_NEAR(guide_pdf(*g, g->roots[0], Vec3f(0, 0, 1)), 0.25 / kPi, 1e-7);
        expect_sane(*g, g->roots[0]);
    }
    {  // one record
        PathGuide guide;
        guide.deposit(0, Vec3f(0.0f), Vec3f(0, 1, 0), 3.0f);
        guide.train(1);
        guide.train(2);
        const GuideView* g = guide.view();
        expect_sane(*g, g->roots[0]);
    }
    {  // all the energy in one direction, huge values, and values that are not numbers
        PathGuide guide;
        const Vec3f d = normalize(Vec3f(1, 2, 3));
        for (int i = 0; i < 100000; ++i) guide.deposit(0, Vec3f(0.0f), d, 1e30f);
        guide.deposit(0, Vec3f(0.0f), d, std::nanf(""));
        guide.deposit(0, Vec3f(0.0f), d, -1.0f);
        guide.deposit(0, Vec3f(0.0f), d, INFINITY);
        guide.train(1);
        for (int i = 0; i < 100000; ++i) guide.deposit(0, Vec3f(0.0f), d, 1e30f);
        guide.train(2);
        const GuideView* g = guide.view();
        // (every record the same, the spatial filter moves them all alike: into one of the
        // cells that meet at their point, the middle of the box)
        uint32_t root = g->roots[guide_cell(*g, Vec3f(0.0f))];
        float peak = 0.0f;
        for (int corner = 0; corner < 8; ++corner) {
            const auto side = [&](int axis) { return (corner >> axis) & 1 ? 1e-30f : -1e-30f; };
            const uint32_t r = g->roots[guide_cell(*g, Vec3f(side(0), side(1), side(2)))];
            expect_sane(*g, r);
            if (guide_pdf(*g, r, d) > peak) peak = guide_pdf(*g, r, d), root = r;
        }
        EXPECT_GT(peak, 50.0f);  // (the learnt trees went deep towards d: 0.08 is uniform)
        float pdf;
        const Vec3f s = guide_sample(*g, root, 0.3f, 0.6f, pdf);
        EXPECT_GT(dot(s, d), 0.99f);
    }
}

// The trees as bytes: the tree over space, the cells' roots and the quadtrees
std::vector<uint8_t> bytes_of(const PathGuide& guide) {
    const GuideView* g = guide.view();
    const GuideStats st = guide.stats();
    std::vector<uint8_t> out;
    const auto put = [&](const void* p, size_t n) {
        const auto* b = static_cast<const uint8_t*>(p);
        out.insert(out.end(), b, b + n);
    };
    put(g->lo, sizeof(g->lo));
    put(g->size, sizeof(g->size));
    put(g->roots, st.cells * sizeof(uint32_t));
    put(g->directions, st.nodes * sizeof(GuideDirectionNode));
    // (the tree over space: walked from the root)
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t n = stack.back();
        stack.pop_back();
        put(&g->spatial[n], sizeof(GuideSpatialNode));
        if (g->spatial[n].child > 0) {
            stack.push_back(uint32_t(g->spatial[n].child));
            stack.push_back(uint32_t(g->spatial[n].child) + 1);
        }
    }
    return out;
}

TEST(Guiding, LearningIsTheSameInAnyOrderAndOnAnyNumberOfThreads) {
    const Vec3f peak = normalize(Vec3f(0.0f, 1.0f, 0.2f));
    std::vector<Record> first = lobe_records(60000, 5, peak),
                        second = lobe_records(120000, 6, peak);
    PathGuide in_order, shuffled, threaded;
    train_on(in_order, first, 1);
    train_on(in_order, second, 2);
    std::mt19937 rng(9);
    std::vector<Record> a = first, b = second;
    std::shuffle(a.begin(), a.end(), rng);
    std::shuffle(b.begin(), b.end(), rng);
    train_on(shuffled, a, 1);
    train_on(shuffled, b, 2);
    for (const std::vector<Record>* records : {&first, &second}) {
        std::vector<std::thread> threads;
        for (size_t t = 0; t < 3; ++t)
            threads.emplace_back([&, t] {
                for (size_t i = t; i < records->size(); i += 3)
                    threaded.deposit(0, (*records)[i].p, (*records)[i].dir, (*records)[i].value);
            });
        for (std::thread& t : threads) t.join();
        threaded.train(records == &first ? 1 : 2);
    }
    const std::vector<uint8_t> reference = bytes_of(in_order);
    EXPECT_GT(in_order.stats().cells, 1u);  // (the tree over space was cut)
    EXPECT_EQ(bytes_of(shuffled), reference);
    EXPECT_EQ(bytes_of(threaded), reference);
}

// The box filter over directions: a deposit spreads over the learning tree's leaves under a
// square the side of its own leaf, centred on it (wrapping across φ's seam); unfiltered, it
// stays in its leaf. The first learning tree is 8 × 8 leaves of side 1/8.
TEST(Guiding, ADepositSpreadsOverTheLeavesAroundItsDirection) {
    const auto trained = [](bool filter, float x, float y) {
        auto guide = std::make_unique<PathGuide>(true, filter);
        guide->deposit(0, Vec3f(0.0f), square_to_direction(x, y), 1.0f);
        guide->train(1);
        return guide;
    };
    const double e = 1.0 / 8.0;
    {  // at the corner of four leaves: a quarter in each
        const auto guide = trained(true, 0.5f, 0.5f);
        const GuideView& g = *guide->view();
        for (const auto& [x, y] : {std::pair{3, 3}, {4, 3}, {3, 4}, {4, 4}})
            EXPECT_NEAR(mass(g, g.roots[0], x * e, y * e, (x + 1) * e, (y + 1) * e), 0.25, 1e-3)
                << x << " " << y;
        const auto nearest = trained(false, 0.5f, 0.5f);
        const GuideView& n = *nearest->view();
        EXPECT_NEAR(mass(n, n.roots[0], 4 * e, 4 * e, 5 * e, 5 * e), 1.0, 1e-6);
    }
    {  // at a leaf's centre: all in it
        const auto guide = trained(true, 0.5f * float(e) + 2 * float(e), 0.5f * float(e));
        const GuideView& g = *guide->view();
        EXPECT_NEAR(mass(g, g.roots[0], 2 * e, 0, 3 * e, e), 1.0, 1e-3);
    }
    {  // near φ = 0 (y): the part of the square below 0 wraps to the top row of leaves
        const float y = 0.25f * float(e);
        const auto guide = trained(true, 4.5f * float(e), y);
        const GuideView& g = *guide->view();
        EXPECT_NEAR(mass(g, g.roots[0], 4 * e, 7 * e, 5 * e, 1.0), (0.5 * e - y) / e, 1e-3);
        EXPECT_NEAR(mass(g, g.roots[0], 4 * e, 0, 5 * e, e), (0.5 * e + y) / e, 1e-3);
    }
}

// The stochastic box filter over space: records just inside one cell, all from one direction,
// teach the neighbouring cell across the boundary that direction too (about half of them land
// there); unfiltered, that cell learns nothing and stays uniform
TEST(Guiding, ADepositReachesTheCellsWithinHalfACellOfIt) {
    for (bool filter : {true, false}) {
        PathGuide guide(true, filter);
        std::mt19937 rng(3);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int i = 0; i < 60000; ++i)
            guide.deposit(0, Vec3f(u(rng), u(rng), u(rng)), uniform_direction(rng), 1.0f);
        guide.train(1);
        ASSERT_GT(guide.stats().cells, 1u);
        // A boundary between cells along x through the cube's middle
        const GuideView* g = guide.view();
        float below = 0.3f;
        const int32_t start = guide_cell(*g, Vec3f(below, 0.5f, 0.5f));
        float above = below;
        while (above < 0.7f && guide_cell(*g, Vec3f(above, 0.5f, 0.5f)) == start) above += 1e-3f;
        ASSERT_NE(guide_cell(*g, Vec3f(above, 0.5f, 0.5f)), start);
        below = above - 1e-3f;
        const Vec3f peak = normalize(Vec3f(0.2f, -0.3f, 0.9f));
        for (int i = 0; i < 20000; ++i) {
            const Vec3f d = normalize(peak + uniform_direction(rng) * 0.05f);
            guide.deposit(0, Vec3f(below + 1e-4f * u(rng), 0.5f, 0.5f), d, 1.0f);
        }
        guide.train(2);
        g = guide.view();
        const float there =
            guide_pdf(*g, g->roots[guide_cell(*g, Vec3f(above + 1e-4f, 0.5f, 0.5f))], peak);
        if (filter)
            EXPECT_GT(there, 20.0f * 0.25f / float(kPi));
        else
            EXPECT_NEAR(there, 0.25f / float(kPi), 1e-6f);
    }
}

// The share α: every cell starts at 0 (the first guide is not sampled) and a training keeps
// the candidate of least estimated second moment, estimated from diffuse records drawn from
// the lobe alone. Where the light comes from a small bright cone the guide has learnt, a
// share of the guide wins; where it comes evenly from everywhere, the cosine lobe is exact
// (f·cos θ·L / p is constant) and 0 stays.
TEST(Guiding, TheShareStartsAtZeroAndGrowsWhereTheGuidePays) {
    const Vec3f peak = normalize(Vec3f(0.3f, 0.2f, 0.9f));
    for (bool bright_cone : {true, false}) {
        SCOPED_TRACE(bright_cone);
        PathGuide guide;
        train_on(guide, lobe_records(200000, 21, peak), 1);
        const GuideView* g = guide.view();
        ASSERT_NE(g, nullptr);
        const uint32_t cells = guide.stats().cells;
        for (uint32_t c = 0; c < cells; ++c) EXPECT_EQ(g->fractions[c], 0.0f) << c;
        // Diffuse records about +z, cosine-distributed, drawn with α = 0
        std::mt19937 rng(22);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int i = 0; i < 200000; ++i) {
            const Vec3f p(u(rng), u(rng), u(rng));
            const float r = std::sqrt(u(rng)), phi = float(2.0 * kPi) * u(rng);
            const Vec3f d(r * std::cos(phi), r * std::sin(phi), std::sqrt(1.0f - r * r));
            const float lobe_pdf = d.z * float(kInvPi);
            const float light = bright_cone && dot(d, peak) > 0.97f ? 100.0f : 1.0f;
            PathGuide::SelectionSample s;
            s.integrand = float(kInvPi) * d.z * light;  // f·cos θ·L, albedo 1
            s.guide_pdf = guide_pdf(*g, g->roots[guide_cell(*g, p)], d);
            s.lobe_pdf = lobe_pdf;
            s.fraction = 0.0f;
            guide.deposit(0, p, d, light / lobe_pdf, &s);
        }
        guide.train(2);
        g = guide.view();
        const uint32_t middle = guide_cell(*g, Vec3f(0.5f));
        if (bright_cone)
            EXPECT_GT(g->fractions[middle], 0.0f);
        else
            EXPECT_EQ(g->fractions[middle], 0.0f);
    }
}

// The tree over space spans the first iteration's vertices but for the farthest half percent
// per axis: a room seen through an open side has a few vertices on its infinite floor
// hundreds of units away, and a box around those left the room one or two cells
TEST(Guiding, TheBoxLeavesOutTheFarthestVertices) {
    PathGuide guide;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int i = 0; i < 100000; ++i) {
        const bool far = i % 1000 == 0;  // (0.1%)
        const Vec3f p(u(rng), u(rng), far ? -300.0f * u(rng) : u(rng));
        guide.deposit(0, p, uniform_direction(rng), 1.0f);
    }
    guide.train(1);
    const GuideView* v = guide.view();
    ASSERT_NE(v, nullptr);
    for (int a = 0; a < 3; ++a) {
        EXPECT_LE(v->lo[a], 0.0f) << a;  // the cube is inside
        EXPECT_GE(v->lo[a] + v->size[a], 1.0f) << a;
        EXPECT_LT(v->size[a], 1.5f) << a;  // the far vertices are not
    }
    // A vertex outside the box still finds a cell (a border cell)
    EXPECT_LT(guide_cell(*v, Vec3f(0.5f, 0.5f, -250.0f)), guide.stats().cells);
}

TEST(Guiding, TheDirectionMapIsAccurateAndInvertible) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int i = 0; i < 100000; ++i) {
        const float y = u(rng), x = u(rng);
        EXPECT_NEAR(guide_atan2(y, x), std::atan2(y, x), 2e-6f) << y << " " << x;
    }
    EXPECT_EQ(guide_atan2(0.0f, 0.0f), 0.0f);
    EXPECT_NEAR(guide_atan2(1.0f, 0.0f), float(0.5 * kPi), 1e-6f);
    EXPECT_NEAR(guide_atan2(0.0f, -1.0f), float(kPi), 1e-6f);
    for (int i = 0; i < 100000; ++i) {
        std::uniform_real_distribution<float> v(0.0f, 1.0f);
        const float x = v(rng), y = v(rng);
        float x2, y2;
        direction_to_square(square_to_direction(x, y), x2, y2);
        EXPECT_NEAR(x2, x, 1e-5f);
        EXPECT_NEAR(std::min(std::abs(y2 - y), 1.0f - std::abs(y2 - y)), 0.0f, 2e-5f)
            << x << " " << y;
    }
}

TEST(Guiding, TrainingsFallOnPowersOfTwo) {
    for (int64_t s : {1, 2, 4, 8, 16, 32, 64, 1024}) EXPECT_TRUE(PathGuide::trains_before(s)) << s;
    for (int64_t s : {0, 3, 48, 96, 1000}) EXPECT_FALSE(PathGuide::trains_before(s)) << s;
}

TEST(Guiding, LearningStopsAtTheTrainingThatReachesItsRecords) {
    // A guide that learns from 250 records: after a training of 200 it still learns, after
    // the next (400 in all) it does not, and its state says so
    PathGuide guide(true, true, kGuideFirstFraction, 250);
    EXPECT_TRUE(guide.learning());
    const auto iteration = [&](int32_t pass, int64_t spp) {
        for (int i = 0; i < 200; ++i)
            guide.deposit(pass, Vec3f(0.01f * float(i), 0.5f, 0.5f), Vec3f(0, 0, 1), 1.0f);
        guide.commit_pass(pass);
        guide.train(spp);
    };
    iteration(0, 1);
    EXPECT_TRUE(guide.learning());
    EXPECT_TRUE(guide.stats().learning);
    iteration(1, 2);
    EXPECT_FALSE(guide.learning());
    EXPECT_FALSE(guide.stats().learning);
    EXPECT_EQ(guide.stats().records, 400u);
    // Later trainings (no records) keep the last guide: its density towards the light it
    // learnt, many times the whole sphere's 1/4π that trees trained on nothing would give
    const GuideView* g = guide.view();
    ASSERT_NE(g, nullptr);
    const float learnt = guide_pdf(*g, g->roots[0], Vec3f(0, 0, 1));
    EXPECT_GT(learnt, 100.0f / (4.0f * float(kPi)));
    guide.commit_pass(2), guide.commit_pass(3);
    guide.train(4), guide.train(8);
    g = guide.view();
    EXPECT_EQ(guide_pdf(*g, g->roots[0], Vec3f(0, 0, 1)), learnt);
    EXPECT_EQ(guide.stats().trained_at, (std::vector<int64_t>{1, 2}));
    EXPECT_EQ(guide.trained_through(), 2);
    PathGuide again(true, true, kGuideFirstFraction, 250);
    again.restore(guide.save());
    EXPECT_FALSE(again.learning());
    PathGuide more(true, true, kGuideFirstFraction, 1000);  // (its own bound: still learning)
    more.restore(guide.save());
    EXPECT_TRUE(more.learning());
}

TEST(Guiding, MemoryStaysWithinItsBounds) {
    // Many records spread everywhere cut the tree over space to its bound on cells
    PathGuide guide;
    for (int64_t spp = 1; spp <= 4; spp *= 2) {
        std::mt19937 rng{uint32_t(spp)};
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        for (int i = 0; i < 400000; ++i) {
            const Vec3f p(u(rng), u(rng), u(rng));
            guide.deposit(0, p, uniform_direction(rng), 1.0f + u(rng));
        }
        guide.train(spp);
    }
    const GuideStats st = guide.stats();
    EXPECT_LE(st.cells, kGuideMaxCells);
    EXPECT_LE(st.nodes + st.learning_nodes, uint64_t(kGuideMaxNodes) + 64u * st.cells);
    EXPECT_GT(st.bytes, st.nodes * sizeof(GuideDirectionNode));
    EXPECT_EQ(st.training_seconds.size(), 3u);
}

// ---- Guided renders ----------------------------------------------------------------------

bool lighter() { return test::lighter_settings(); }

Scene guided(Scene s, Estimator e, int spp, Guiding g = Guiding::kSdTree) {
    test::set_estimator(s, e);
    s.settings.estimator.guiding = g;
    s.settings.spp = spp;
    return s;
}

// (`first_fraction`: the cells' share α before their records choose one; ½ has a small
// render sample its guide, where the default, 0, may never)
RenderResult render_on(const Scene& scene, int threads, bool merge_threads = true,
                       std::optional<float> first_fraction = {},
                       Integrator integrator = Integrator::kScalar) {
    RenderOptions o;
    o.integrator = integrator;
    o.threads = threads;
    o.progress = false;
    o.guide_merges_threads = merge_threads;
    o.guide_first_fraction = first_fraction;
    return render(scene, o);
}

bool same_bits(const Film& a, const Film& b) {
    return a.pixels().size() == b.pixels().size() &&
           std::memcmp(a.pixels().data(), b.pixels().data(),
                       a.pixels().size() * sizeof(PixelSums)) == 0;
}

// Both integrators, by name (the wavefront's guided paths: guide_stage.h)
const Integrator kIntegrators[] = {Integrator::kScalar, Integrator::kWavefront};

TEST(GuidedRender, IsTheSameOnOneTwoAndThreeThreads) {
    // (the guide at every vertex, whose many records cut the space into cells even in the
    // emulator's small renders, and at the first vertex alone, the default; lobes.json has
    // several lobe kinds, which the wavefront samples in its lobe buckets, and
    // small_emitter's one lobe it samples as it shades)
    for (Integrator in : kIntegrators)
        for (const char* scene : {"lobes", "small_emitter"})
            for (Estimator e : {Estimator::kNee, Estimator::kMis})
                for (int vertices : {0, 1}) {
                    if (std::string(scene) == "small_emitter" &&
                        (in == Integrator::kScalar || e == Estimator::kNee || vertices == 0))
                        continue;
                    // (the lighter settings, under emulation and sanitizers, check mis
                    // alone: nee's guided paths are the same code without its light hits,
                    // checked here natively)
                    if (lighter() && e == Estimator::kNee) continue;
                    SCOPED_TRACE(std::string(integrator_name(in)) + " " + scene + " " +
                                 estimator_name(e) + " " + std::to_string(vertices));
                    // (trainings after 16 and 32 paths per pixel, and after 64 natively)
                    Scene s =
                        guided(std::string(scene) == "lobes"
                                   ? parse_scene(test::kLobes, "lobes.json")
                                   : load_scene(CIERZO_SOURCE_DIR "/scenes/small_emitter.json"),
                               e, lighter() ? 48 : 128);
                    s.set_resolution(lighter() ? 32 : 48, lighter() ? 24 : 32);
                    s.settings.estimator.guided_vertices = vertices;
                    const RenderResult one = render_on(s, 1, true, 0.5f, in);
                    ASSERT_TRUE(one.stats.guiding);
                    EXPECT_GE(one.stats.guiding->training_seconds.size(), 2u);  // (16, 32, ...)
                    if (vertices == 0) {
                        EXPECT_GT(one.stats.guiding->cells, 1u);
                    }
                    EXPECT_EQ(one.stats.nonfinite_samples, 0u);
                    // (and the default share, α = 0 until the records choose one: the
                    // scalar loop's)
                    for (int threads : {2, 3}) {
                        EXPECT_TRUE(same_bits(render_on(s, threads, true, 0.5f, in).film, one.film))
                            << threads;
                        if (in == Integrator::kScalar) {
                            EXPECT_TRUE(same_bits(render_on(s, threads, true, {}, in).film,
                                                  render_on(s, 1, true, {}, in).film))
                                << threads;
                        }
                    }
                    // The guide changed the image: it is not the unguided one
                    Scene plain = s;
                    plain.settings.estimator.guiding = Guiding::kNone;
                    EXPECT_FALSE(same_bits(render_on(plain, 1, true, {}, in).film, one.film));
                }
}

// The guide a render's final state holds, trained on the passes of that state (those since
// the last training).
std::unique_ptr<PathGuide> trained_guide(const Scene& scene, Integrator in, int64_t spp) {
    RenderOptions o;
    o.integrator = in;
    o.threads = 2;
    o.progress = false;
    o.guide_first_fraction = 0.5f;
    RenderState last;
    o.checkpoint = [&](const RenderState& st) { last = st; };
    render(scene, o);
    auto guide = std::make_unique<PathGuide>();
    guide->restore(last.guide);
    guide->train(spp);
    return guide;
}

TEST(GuidedRender, TheWavefrontRecordsWhatTheScalarLoopRecords) {
    // The two integrators draw the same paths (to float rounding), so the records their paths
    // hand the guide are the same: as many, with the same light in the same directions. Two
    // passes of 16 paths per pixel: the first without a guide, the second drawing half its
    // diffuse directions from the guide the first trained, its records with the mixture's
    // densities. The guide trained from that second pass is compared, quadrant by quadrant,
    // at every cell's root: the shares differ by 10⁻⁸–10⁻⁴. A record that took its own
    // vertex's direct light (planted: 0.05–0.21), or that divided by the lobe's density where
    // the direction was drawn from the mixture (planted: 0.02–0.04), moves them by far more.
    for (const char* name : {"lobes", "small_emitter", "room"})
        for (int vertices : {1, 0}) {
            SCOPED_TRACE(std::string(name) + " " + std::to_string(vertices));
            Scene s = std::string(name) == "lobes" ? parse_scene(test::kLobes, "lobes.json")
                      : std::string(name) == "room"
                          ? parse_scene(test::kRoom, "room.json")
                          : load_scene(CIERZO_SOURCE_DIR "/scenes/small_emitter.json");
            // (passes of 16 paths per pixel, the first trained on at 16; with the guide at
            // every vertex, one pass: its paths' many records each, without a guide to draw
            // from, where the second pass's paths, drawing from it at every vertex, part
            // as rounding moves a number across a quadrant's edge)
            const int spp = vertices == 1 ? 32 : 16;
            s = guided(s, Estimator::kMis, spp);
            s.settings.estimator.guided_vertices = vertices;
            s.set_resolution(32, 32);
            const auto scalar = trained_guide(s, Integrator::kScalar, spp);
            const auto wavefront = trained_guide(s, Integrator::kWavefront, spp);
            const GuideStats a = scalar->stats(), b = wavefront->stats();
            EXPECT_NEAR(double(b.records), double(a.records), 0.002 * double(a.records));
            ASSERT_EQ(a.cells, b.cells);
            const GuideView* va = scalar->view();
            const GuideView* vb = wavefront->view();
            ASSERT_TRUE(va && vb);
            double largest = 0;
            for (uint32_t c = 0; c < a.cells; ++c) {
                const GuideDirectionNode& x = va->directions[va->roots[c]];
                const GuideDirectionNode& y = vb->directions[vb->roots[c]];
                for (int q = 0; q < 4; ++q)
                    largest = std::max(largest, double(std::abs(x.energy[q] - y.energy[q])));
            }
            EXPECT_LT(largest, 0.01);
        }
}

TEST(GuidedRender, PathsStopRecordingWhenTheGuideStopsLearning) {
    // A guide that stops learning at the first training (16 paths per pixel: more records
    // than its bound): the later passes sample it and record nothing, on both integrators,
    // with the same bits on one and three threads and after a resume; the image is not the
    // one of a guide that learns on
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 64);
    s.set_resolution(32, 24);
    for (Integrator in : kIntegrators) {
        SCOPED_TRACE(integrator_name(in));
        RenderOptions o;
        o.integrator = in;
        o.progress = false;
        o.guide_first_fraction = 0.5f;
        o.threads = 1;
        const RenderResult on = render(s, o);
        o.guide_learn_records = 1000;
        const RenderResult stopped = render(s, o);
        o.threads = 3;
        const RenderResult three = render(s, o);
        ASSERT_TRUE(on.stats.guiding && stopped.stats.guiding);
        EXPECT_TRUE(on.stats.guiding->learning);
        EXPECT_FALSE(stopped.stats.guiding->learning);
        // (the first pass's records alone: at most one a path)
        EXPECT_GT(stopped.stats.guiding->records, 1000u);
        EXPECT_LE(stopped.stats.guiding->records, uint64_t(32 * 24 * 16));
        EXPECT_GT(on.stats.guiding->records, 3 * stopped.stats.guiding->records);
        EXPECT_TRUE(same_bits(three.film, stopped.film));
        EXPECT_FALSE(same_bits(on.film, stopped.film));
        EXPECT_EQ(stopped.stats.nonfinite_samples, 0u);
        // A render of 96 paths stopped at 48 (after the training at 32, which the stopped
        // guide skips) and resumed on two threads, through the training at 64: the bits of
        // the render not stopped
        Scene longer = s, part = s;
        longer.settings.spp = 96;
        part.settings.spp = 48;
        RenderState st;
        RenderOptions first = o;
        first.threads = 1;
        first.checkpoint = [&](const RenderState& state) { st = state; };
        render(part, first);
        ASSERT_EQ(st.spp_done, 48);
        RenderOptions again = o;
        again.threads = 2;
        again.resume = &st;
        EXPECT_TRUE(same_bits(render(longer, again).film, render(longer, o).film));
        // (--stats: the wavefront's records wait in its threads' tables, the scalar loop's
        // on its stack)
        if (in == Integrator::kWavefront)
            EXPECT_GE(on.stats.guiding->record_table_bytes, 4096u * sizeof(GuideRecord));
        else
            EXPECT_EQ(on.stats.guiding->record_table_bytes, 0u);
    }
}

TEST(GuidedRender, BandsOfPathLengthsAddUpToTheWholeImage) {
    // The guide learns from the whole light whatever lengths the film counts, so the images
    // of lengths 1..2, 3 and 4.. are the same paths with the same guide: they add up, pixel
    // by pixel, to the whole image (but for the rounding of the film's sums). A guide that
    // learnt from its band's light alone would draw other paths in each band, off by noise.
    for (Estimator e : {Estimator::kNee, Estimator::kMis}) {
        SCOPED_TRACE(estimator_name(e));
        // (trainings after 16 and 32 paths per pixel)
        Scene s = guided(parse_scene(test::kLobes, "lobes.json"), e, 48);
        s.set_resolution(32, 24);
        const auto image = [&](int lo, int hi) {
            Scene band = s;
            band.settings.estimator.min_length = lo;
            band.settings.estimator.max_length = hi;
            return render_on(band, 2, true, 0.5f).film.mean();
        };
        const Image whole = image(1, kNoLengthLimit), direct = image(1, 2), first = image(3, 3),
                    rest = image(4, kNoLengthLimit);
        double largest = 0, worst = 0, in_bands[3] = {0, 0, 0};
        for (size_t i = 0; i < whole.rgb.size(); ++i) {
            const double sum = double(direct.rgb[i]) + first.rgb[i] + rest.rgb[i];
            largest = std::max(largest, double(whole.rgb[i]));
            worst = std::max(worst, std::abs(sum - whole.rgb[i]));
            in_bands[0] += direct.rgb[i], in_bands[1] += first.rgb[i], in_bands[2] += rest.rgb[i];
        }
        EXPECT_LE(worst, 1e-5 * largest + 1e-6);
        for (double b : in_bands) EXPECT_GT(b, 0.0);
    }
}

TEST(GuidedRender, TheGuideServesTheVerticesItIsGiven) {
    // render.guided_vertices: the guide draws, weighs and learns at a camera path's first N
    // Phong vertices alone (0: every one). Its records say where it learnt: at most one a
    // path for N = 1, at most two for N = 2, and more than two a path where every vertex of
    // a closed room's paths records. A setting that was ignored would record alike in all
    // three, and draw the same image
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 48);
    s.set_resolution(16, 16);
    const double paths = 16.0 * 16.0 * 48.0;
    for (Integrator in : kIntegrators) {
        SCOPED_TRACE(integrator_name(in));
        double records[3] = {0, 0, 0};
        std::vector<Film> films;
        for (int n : {0, 1, 2}) {
            SCOPED_TRACE(n);
            s.settings.estimator.guided_vertices = n;
            const RenderResult r = render_on(s, 2, true, 0.5f, in);
            ASSERT_TRUE(r.stats.guiding);
            records[n] = double(r.stats.guiding->records);
            EXPECT_EQ(r.stats.nonfinite_samples, 0u);
            films.push_back(r.film);
        }
        EXPECT_LE(records[1], paths);
        EXPECT_GT(records[1], 0.5 * paths);  // (most paths reach a Phong vertex)
        EXPECT_LE(records[2], 2.0 * paths);
        EXPECT_GT(records[2], records[1]);
        EXPECT_GT(records[0], 2.0 * paths);
        EXPECT_FALSE(same_bits(films[0], films[1]));
        EXPECT_FALSE(same_bits(films[1], films[2]));
    }
}

TEST(GuidedRender, GuidedVerticesAreReadAndChecked) {
    const std::string head = R"({"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
        "materials": {"w": {"kd": 0.5}}, "objects": [{"type": "plane", "normal": [0, 1, 0],
        "distance": 1, "material": "w"}], "render": {"estimator": "mis", "guiding": "sdtree", )";
    EXPECT_EQ(parse_scene(head + R"("seed": 1}})", "g.json").settings.estimator.guided_vertices, 1);
    EXPECT_EQ(parse_scene(head + R"("guided_vertices": 0}})", "g.json")
                  .settings.estimator.guided_vertices,
              0);
    EXPECT_EQ(parse_scene(head + R"("guided_vertices": 3}})", "g.json")
                  .settings.estimator.guided_vertices,
              3);
    for (const char* bad : {R"("guided_vertices": -1}})", R"("guided_vertices": 1.5}})",
                            R"("guided_vertices": "all"}})"}) {
        try {
            parse_scene(head + bad, "g.json");
            ADD_FAILURE() << "accepted " << bad;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("g.json"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("guided_vertices"), std::string::npos) << e.what();
        }
    }
}

TEST(GuidedRender, AnalyticAnswers) {
    // A point light in a diffuse sphere, and a diffuse ball inside an emitting sphere (a
    // furnace: every point of it sees the emitter alone)
    const int spp = lighter() ? 64 : 256;
    const double bound = lighter() ? 0.03 : 0.015;
    // (the guide at the first vertex, the default, and at every vertex)
    for (Integrator in : kIntegrators)
        for (Estimator e : {Estimator::kNee, Estimator::kMis})
            for (int vertices : {1, 0}) {
                SCOPED_TRACE(std::string(integrator_name(in)) + " " + estimator_name(e) + " " +
                             std::to_string(vertices));
                Scene room = guided(parse_scene(test::kRoom, "room.json"), e, spp);
                room.settings.estimator.guided_vertices = vertices;
                room.set_resolution(32, 32);
                test::expect_answer(render_on(room, 2, true, {}, in), test::kRoomL, bound);
                Scene ball = guided(parse_scene(test::kBall, "ball.json"), e, spp);
                ball.settings.estimator.guided_vertices = vertices;
                ball.set_resolution(32, 32);
                test::expect_answer(render_on(ball, 2, true, {}, in), 0.8, bound);
            }
}

// A diffuse floor (ρ = 0.5) under an emitting sphere (Le 1, radius 0.5, centre 1 above the
// floor's point the camera sees): L = ρ·Le·sin²θ = 0.5 · 0.25 = 0.125 there, and nothing else
// reaches it (the sphere absorbs; the floor is flat)
const char* kFloorUnderSphere = R"({"render": {"width": 16, "height": 16, "seed": 3},
    "camera": {"position": [0, 2, -2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 0.5},
    "materials": {"floor": {"kd": 0.5}, "L": {"emission": 1}},
    "objects": [{"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "floor"},
                {"type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "L"}]})";

TEST(GuidedRender, AGuideDensityLeftOutOfTheEmitterSampleWeightIsCaught) {
    const int spp = lighter() ? 128 : 512;
    for (Integrator in : kIntegrators) {
        SCOPED_TRACE(integrator_name(in));
        Scene s = guided(parse_scene(kFloorUnderSphere, "floor.json"), Estimator::kMis, spp);
        const RenderResult right = render_on(s, 2, true, {}, in);
        test::expect_answer(right, 0.125, 0.01);
        // The planted bug: the emitter sample's MIS weight without the guide's density
        s.settings.estimator.guide_in_mis = false;
        const RenderResult wrong = render_on(s, 2, true, {}, in);
        const test::ImageMean m = test::image_mean(wrong.film, 1);
        EXPECT_GT(std::abs(m.mean - 0.125), 5.0 * m.sigma) << m.mean << " ± " << m.sigma;
    }
}

TEST(GuidedRender, TrainingOnAnUnmergedPassIsCaught) {
    // The planted bug: the training takes the records of one thread alone, not the whole
    // pass merged, so the image depends on which thread rendered what
    // (trainings after 16, 32 and 64 paths per pixel)
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 128);
    s.set_resolution(lighter() ? 32 : 48, lighter() ? 24 : 32);
    for (Integrator in : kIntegrators) {
        SCOPED_TRACE(integrator_name(in));
        const RenderResult one = render_on(s, 1, false, 0.5f, in);
        bool differs = false;
        for (int k = 0; k < 4 && !differs; ++k)
            differs = !same_bits(render_on(s, 3, false, 0.5f, in).film, one.film);
        EXPECT_TRUE(differs);
    }
}

TEST(GuidedRender, AgreesWithMisPerPixelOnEveryScene) {
    // Guided and unguided mis, per pixel (z-test at the Šidák-corrected level), on every
    // scene of scenes/ at 32 × 32 (under an emulator, the scenes guiding acts on most)
    const int spp = lighter() ? 64 : 256;
    for (const std::filesystem::path& path : test::all_scenes()) {
        SCOPED_TRACE(path.filename().string());
        const std::string name = path.stem().string();
        if (lighter() && name != "small_emitter" && name != "caustic" && name != "four_lobes")
            continue;
        Scene scene = load_scene(path);
        scene.set_resolution(32, 32);
        // (the guided wavefront against the unguided scalar loop)
        for (Integrator in : kIntegrators) {
            SCOPED_TRACE(integrator_name(in));
            Scene g = guided(scene, Estimator::kMis, spp);
            Scene plain = guided(scene, Estimator::kMis, spp, Guiding::kNone);
            plain.settings.seed = g.settings.seed + 1;
            const RenderResult a = render_on(g, 2, true, {}, in), b = render_on(plain, 2);
            EXPECT_EQ(a.stats.nonfinite_samples, 0u);
            EXPECT_GE(test::pixels_agreeing(a.film, b.film), 0.99);
        }
    }
}

// ---- Checkpoints -------------------------------------------------------------------------

namespace fs = std::filesystem;
const fs::path kDir = fs::temp_directory_path() / ("cierzo_guide_" + std::to_string(getpid()));
const test::RemovedAtExit kDirRemoved{kDir};

RenderOptions scalar_options(int threads, Integrator integrator = Integrator::kScalar) {
    RenderOptions o;
    o.integrator = integrator;
    o.threads = threads;
    o.progress = false;
    return o;
}

// The state a render of `scene` to `spp` paths per pixel ends with.
RenderState final_state(Scene scene, int64_t spp, Integrator in = Integrator::kScalar) {
    scene.settings.spp = spp;
    RenderOptions o = scalar_options(2, in);
    RenderState last;
    o.checkpoint = [&](const RenderState& s) { last = s; };
    render(scene, o);
    return last;
}

RenderResult resumed_from(const Scene& scene, const RenderState& state, int threads,
                          Integrator in = Integrator::kScalar) {
    RenderOptions o = scalar_options(threads, in);
    o.resume = &state;
    return render(scene, o);
}

// A guided render's checkpoint holds its guide and whole passes. Resumed (on another number
// of threads) it ends in the uninterrupted render's bits: from the end of a pass between
// two trainings (the guide's sums of the iteration's passes so far must be exact), from a
// training point reached before its training (a render of 16 paths per pixel ends before the
// training at 16), and from states taken every millisecond (mid-pass: that pass is rendered
// again), each written to a file and read back.
TEST(GuidedRender, EveryCheckpointResumesToTheUninterruptedBits) {
    // (passes end at 1, 2, 4, 8, 16, 32, 48, 64, 80: trainings at the powers of two; the
    // guide at every vertex, whose records are enough in the emulator's small renders for
    // the planted bug below to change the trees it trains)
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 80);
    s.settings.estimator.guided_vertices = 0;
    s.set_resolution(lighter() ? 32 : 48, lighter() ? 24 : 32);
    const RenderResult full = render_on(s, 2);
    for (int64_t spp : {16, 48}) {
        SCOPED_TRACE(spp);
        const RenderState st = final_state(s, spp);
        ASSERT_EQ(st.spp_done, spp);
        ASSERT_FALSE(st.guide.empty());
        const RenderResult resumed = resumed_from(s, st, 3);
        EXPECT_TRUE(same_bits(resumed.film, full.film));
        // (the guide too: it learnt from every record of the uninterrupted render)
        ASSERT_TRUE(resumed.stats.guiding && full.stats.guiding);
        EXPECT_EQ(resumed.stats.guiding->records, full.stats.guiding->records);
        // The planted bug: the iteration's sums left out of the state. The next training
        // learns from fewer records, and trains another guide (the image may not show it:
        // where every cell keeps α = 0 the trees are not sampled)
        if (spp == 48) {
            PathGuide g;
            g.restore(st.guide, false);
            RenderState without = st;
            without.guide = g.save();
            const RenderResult wrong = resumed_from(s, without, 3);
            ASSERT_TRUE(wrong.stats.guiding);
            EXPECT_LT(wrong.stats.guiding->records, full.stats.guiding->records);
            const GuideStats &a = *wrong.stats.guiding, &b = *full.stats.guiding;
            EXPECT_TRUE(a.cells != b.cells || a.nodes != b.nodes ||
                        a.cells_by_fraction != b.cells_by_fraction);
        }
    }

    std::vector<RenderState> states;
    std::mutex m;
    RenderOptions o = scalar_options(2);
    o.checkpoint_every = 0.001;
    o.checkpoint = [&](const RenderState& st) {
        std::lock_guard lock(m);
        states.push_back(st);
    };
    ASSERT_TRUE(same_bits(render(s, o).film, full.film)) << "checkpointing changed the image";
    std::map<int64_t, const RenderState*> by_spp;  // (one state per paths reached)
    for (const RenderState& st : states) {
        EXPECT_TRUE(st.pending_tiles.empty());
        EXPECT_FALSE(st.guide.empty());
        by_spp[st.spp_done] = &st;
    }
    // (under an emulator, two of them: the first mid-render and the last)
    while (lighter() && by_spp.size() > 2) by_spp.erase(std::next(by_spp.begin()));
    fs::create_directories(kDir);
    const CheckpointIdentity id = checkpoint_identity(s, "scalar", "scalar", 0);
    for (const auto& [spp, st] : by_spp) {
        SCOPED_TRACE(spp);
        const fs::path file = kDir / ("guided_" + std::to_string(spp) + ".exr");
        write_checkpoint(file, id, *st);
        const Checkpoint c = read_checkpoint(file);
        ASSERT_EQ(c.state.guide, st->guide);
        EXPECT_TRUE(same_bits(resumed_from(s, c.state, 1).film, full.film));
    }
}

TEST(GuidedRender, TheWavefrontResumesToTheUninterruptedBits) {
    // The wavefront's guided render, stopped at a training point before its training (16)
    // and between two (48), resumed on another number of threads: the uninterrupted bits
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 80);
    s.set_resolution(lighter() ? 32 : 48, lighter() ? 24 : 32);
    RenderOptions o = scalar_options(2, Integrator::kWavefront);
    o.guide_first_fraction = 0.5f;
    const RenderResult full = render(s, o);
    for (int64_t spp : {16, 48}) {
        SCOPED_TRACE(spp);
        Scene part = s;
        part.settings.spp = spp;
        RenderState st;
        o.checkpoint = [&](const RenderState& state) { st = state; };
        render(part, o);
        ASSERT_EQ(st.spp_done, spp);
        RenderOptions again = scalar_options(3, Integrator::kWavefront);
        again.guide_first_fraction = 0.5f;
        again.resume = &st;
        const RenderResult resumed = render(s, again);
        EXPECT_TRUE(same_bits(resumed.film, full.film));
        ASSERT_TRUE(resumed.stats.guiding && full.stats.guiding);
        EXPECT_EQ(resumed.stats.guiding->records, full.stats.guiding->records);
    }
    o.checkpoint = nullptr;
    Scene plain = s;
    plain.settings.estimator.guiding = Guiding::kNone;
    EXPECT_FALSE(same_bits(render(plain, o).film, full.film));
}

TEST(GuidedRender, ACheckpointWithADamagedGuideOrOfAnUnguidedRenderIsRefused) {
    Scene s = guided(parse_scene(test::kLobes, "lobes.json"), Estimator::kMis, 8);
    s.set_resolution(16, 16);
    const RenderState st = final_state(s, 8);
    fs::create_directories(kDir);
    const CheckpointIdentity id = checkpoint_identity(s, "scalar", "scalar", 0);
    for (int damage = 0; damage < 3; ++damage) {
        RenderState bad = st;
        if (damage == 0) bad.guide.resize(bad.guide.size() / 2);  // truncated
        if (damage == 1) bad.guide.push_back(0);                  // longer than its contents
        if (damage == 2) bad.guide[3] ^= 0x20;                    // not a guide's state
        const fs::path file = kDir / ("damaged_" + std::to_string(damage) + ".exr");
        write_checkpoint(file, id, bad);
        try {
            read_checkpoint(file);
            ADD_FAILURE() << "a damaged guide was read: " << damage;
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("path guide"), std::string::npos) << e.what();
        }
    }
    // A guided checkpoint is not resumed unguided, nor an unguided one guided
    Scene plain = s;
    plain.settings.estimator.guiding = Guiding::kNone;
    Checkpoint c{id, st};
    EXPECT_THROW(check_resume("g.exr", c, checkpoint_identity(plain, "scalar", "scalar", 0)),
                 InputError);
    c.id = checkpoint_identity(plain, "scalar", "scalar", 0);
    EXPECT_THROW(check_resume("p.exr", c, id), InputError);
    // nor one whose guide served other vertices
    Scene deeper = s;
    deeper.settings.estimator.guided_vertices = 0;
    c.id = id;
    EXPECT_THROW(check_resume("d.exr", c, checkpoint_identity(deeper, "scalar", "scalar", 0)),
                 InputError);
    // An unguided state has no guide for a guided render to go on from
    RenderState none = st;
    none.guide.clear();
    EXPECT_THROW(resumed_from(s, none, 1), InputError);
}

TEST(GuidedRender, RefusedWhereItIsNotSupported) {
    Scene s = guided(parse_scene(test::kRoom, "room.json"), Estimator::kBdpt, 16);
    EXPECT_THROW(render_on(s, 1), InputError);
    // The wavefront's guided paths do not go on past render.max_length (the scalar loop's do)
    s = guided(parse_scene(test::kRoom, "room.json"), Estimator::kMis, 16);
    s.settings.estimator.max_length = 3;
    try {
        render_on(s, 1, true, {}, Integrator::kWavefront);
        ADD_FAILURE() << "the wavefront rendered a guided band of lengths";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("--integrator scalar"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("room.json"), std::string::npos);
    }
    EXPECT_NO_THROW(render_on(s, 1));
}

}  // namespace
}  // namespace cierzo
