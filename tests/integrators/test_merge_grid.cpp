// vcm's range search (src/integrators/merge_grid.h) against brute force: every point of the
// query's set within its radius is in the buckets the grid names, each bucket once, for
// random points on planes and in space, sets of different radii (tiny, ordinary, larger
// than the scene), positions far from the origin, and points or queries not finite.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include "integrators/merge_grid.h"

namespace cierzo {
namespace {

// The grid's points of set `set` within `radius` of q, by their index in photons().
std::multiset<const Photon*> found(const MergeGrid& g, const float q[3], int32_t set,
                                   float radius) {
    MergeGrid::Range cells[8];
    const int n = g.cells(q[0], q[1], q[2], set, cells);
    EXPECT_LE(n, 8);
    std::multiset<const Photon*> out;
    std::set<int32_t> begins;
    for (int k = 0; k < n; ++k) {
        EXPECT_TRUE(begins.insert(cells[k].begin).second) << "a bucket named twice";
        for (int32_t e = cells[k].begin; e < cells[k].end; ++e) {
            const Photon& p = g.photons()[e];
            const double dx = p.p[0] - q[0], dy = p.p[1] - q[1], dz = p.p[2] - q[2];
            if (p.set == uint32_t(set) && dx * dx + dy * dy + dz * dz <= double(radius) * radius)
                out.insert(&p);
        }
    }
    return out;
}

TEST(MergeGrid, FindsWhatBruteForceFinds) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (float offset : {0.0f, 1e4f, -3e6f})
        for (bool planar : {true, false}) {
            SCOPED_TRACE("offset " + std::to_string(offset) + (planar ? " planar" : " in space"));
            const std::vector<float> radius = {1e-3f, 0.05f, 0.2f, 5.0f};
            std::vector<Photon> points(4000);
            for (size_t i = 0; i < points.size(); ++i) {
                Photon& p = points[i];
                p.p[0] = offset + u(rng), p.p[1] = planar ? offset - 1.0f : offset + u(rng);
                p.p[2] = offset + u(rng);
                p.set = uint32_t(i % radius.size());
                p.length = uint32_t(i);  // (to tell the points apart)
            }
            MergeGrid g;
            g.build(points.data(), points.size(), radius.data(), radius.size());
            int hits = 0;
            for (int q = 0; q < 2000; ++q) {
                const int32_t set = q % int32_t(radius.size());
                // (half the queries at a point's own position, half anywhere)
                const Photon& near = points[size_t(rng() % points.size())];
                float x[3] = {offset + u(rng), planar ? offset - 1.0f : offset + u(rng),
                              offset + u(rng)};
                if (q % 2) x[0] = near.p[0], x[1] = near.p[1], x[2] = near.p[2];
                const std::multiset<const Photon*> f = found(g, x, set, radius[size_t(set)]);
                // Brute force, by the points' own tags
                std::multiset<uint32_t> expect, got;
                for (const Photon& p : points) {
                    const double dx = p.p[0] - x[0], dy = p.p[1] - x[1], dz = p.p[2] - x[2];
                    const double r = radius[size_t(set)];
                    if (p.set == uint32_t(set) && dx * dx + dy * dy + dz * dz <= r * r)
                        expect.insert(p.length);
                }
                for (const Photon* p : f) got.insert(p->length);
                ASSERT_EQ(got, expect) << "query " << q << " set " << set;
                hits += int(expect.size());
            }
            EXPECT_GT(hits, 2000);  // (the queries found something to compare)
        }
}

TEST(MergeGrid, NothingNotFiniteIsFoundOrAsked) {
    const float inf = std::numeric_limits<float>::infinity(), nan = std::nanf("");
    std::vector<Photon> points(3);
    for (Photon& p : points) p.p[0] = p.p[1] = p.p[2] = 0.0f, p.set = 0;
    points[1].p[0] = nan, points[2].p[2] = inf;
    MergeGrid g;
    const std::vector<float> radius = {0.5f, 0.0f};
    g.build(points.data(), points.size(), radius.data(), radius.size());
    const float origin[3] = {0.0f, 0.0f, 0.0f};
    EXPECT_EQ(found(g, origin, 0, 0.5f).size(), 1u);
    MergeGrid::Range cells[8];
    EXPECT_EQ(g.cells(nan, 0.0f, 0.0f, 0, cells), 0);
    EXPECT_EQ(g.cells(0.0f, inf, 0.0f, 0, cells), 0);
    EXPECT_EQ(g.cells(0.0f, 0.0f, 0.0f, 1, cells), 0);  // (a set of radius 0)
    EXPECT_EQ(g.cells(0.0f, 0.0f, 0.0f, 7, cells), 0);  // (a set the grid does not have)
    EXPECT_EQ(g.cells(0.0f, 0.0f, 0.0f, -1, cells), 0);
}

}  // namespace
}  // namespace cierzo
