// vcm's range search over a unit's light vertices: a hashed uniform grid (as photon maps
// use), built once per unit and asked, for each Phong camera vertex, which of its buckets
// can hold the vertices within the radius. Compiled once (scalar code): both integrators and
// every ISA's kernels use the same grid, so they find the same vertices.
//
// The points come in sets (a unit's light vertices per sample index), each with a radius
// of its own and a hash table of its own (so the buckets a run of camera paths of one
// sample asks for stay in cache); a set's cells are 2·radius wide, so the points within the
// radius of any position lie in the 2 × 2 × 2 cells nearest it. A bucket may also hold
// points of other cells, which the caller's distance test leaves out. The points are kept
// bucket by bucket with what merging reads of them, one cache line each.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace cierzo {

// A stored light vertex as merging reads it (kernels/bidirectional.h, merge_vertices).
struct alignas(64) Photon {
    float p[3];     // position
    float wl[3];    // unit, towards the previous vertex
    float beta[3];  // the light subpath's throughput arriving
    float vcm, vm;  // its MIS quantities (dVC is not read by merging)
    uint32_t length;  // segments from the light
    uint32_t set;     // its set (the sample's offset in the unit)
};

class MergeGrid {
public:
    // A bucket of photons(): [begin, end).
    struct Range {
        int32_t begin, end;
    };

    // Builds the grid over `points` (set p.set, whose radius is radius[set]; sets beyond
    // `radius`, of radius 0 or not finite, find nothing and are left out, as are points not
    // finite).
    void build(std::span<const Photon> points, std::span<const float> radius);

    // The buckets that can hold the points of set `set` within its radius of (x, y, z),
    // each once: their count (at most 8, 0 for a position not finite), written to `out`.
    int cells(float x, float y, float z, int32_t set, Range out[8]) const;

    // The points, bucket by bucket.
    const Photon* photons() const { return sorted_.data(); }

    size_t bytes() const {
        return begin_.capacity() * sizeof(int32_t) + sorted_.capacity() * sizeof(Photon) +
               (inverse_cell_.capacity() + 0) * sizeof(double) +
               (table_.capacity() + scratch_.capacity()) * sizeof(uint32_t);
    }

private:
    std::vector<double> inverse_cell_;  // per set: 1 / (2·radius), 0 when it finds nothing
    std::vector<uint32_t> table_;       // per set: its first bucket, and its mask (pairs)
    std::vector<int32_t> begin_;        // per bucket + 1: its first photon
    std::vector<Photon> sorted_;
    std::vector<uint32_t> scratch_;     // each point's bucket (or ~0: left out), and counts
};

// A unit's merging quantities per sample index (kernels/bidirectional.h's MergeWeights and
// the radius), by the sample's offset in the unit.
struct MergeTable {
    int32_t paths_per_sample = 1;  // the unit's light subpaths per sample index (its pixels)
    std::vector<float> vm_weight, vc_weight, normalization, radius2, radius;
    std::vector<Photon> photons;   // the unit's stored light vertices, before the grid sorts them
    void resize(size_t samples) {
        for (std::vector<float>* v : {&vm_weight, &vc_weight, &normalization, &radius2, &radius})
            v->resize(samples);
    }
};

}  // namespace cierzo
