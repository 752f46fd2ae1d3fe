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

#include <cstddef>
#include <cstdint>
#include <vector>

namespace cierzo {

// A stored light vertex as merging reads it (kernels/bidirectional.h, merge_vertices).
struct alignas(64) Photon {
    float p[3];       // position
    float wl[3];      // unit, towards the previous vertex
    float beta[3];    // the light subpath's throughput arriving
    float vcm, vm;    // its MIS quantities (dVC is not read by merging)
    uint32_t length;  // segments from the light
    uint32_t set;     // its set (the sample's offset in the unit)
};

class MergeGrid {
public:
    // A bucket of photons(): [begin, end).
    struct Range {
        int32_t begin, end;
    };

    // Builds the grid over points[0, count) (set p.set, whose radius is radius[set]; sets
    // from `sets` on, of radius 0 or not finite, find nothing and are left out, as are points
    // not finite).
    void build(const Photon* points, size_t count, const float* radius, size_t sets);

    // The buckets that can hold the points of set `set` within its radius of (x, y, z),
    // each once: their count (at most 8, 0 for a position not finite), written to `out`.
    int cells(float x, float y, float z, int32_t set, Range out[8]) const;

    // The points, bucket by bucket.
    const Photon* photons() const { return photons_; }

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
    const Photon* photons_ = nullptr;  // sorted_'s (the kernels read no std::vector)
    std::vector<uint32_t> scratch_;    // each point's bucket (or ~0: left out), and counts
};

// A unit's merging quantities per sample index (kernels/bidirectional.h's MergeWeights and
// the radius), by the sample's offset in the unit, and its photons before the grid sorts
// them. The kernels read and write them through the plain pointers (every std::vector
// operation is compiled once, here, not in each ISA's objects).
struct MergeTable {
    int32_t paths_per_sample = 1;  // the unit's light subpaths per sample index (its pixels)
    int32_t samples = 0;
    float *vm_weight = nullptr, *vc_weight = nullptr, *normalization = nullptr, *radius2 = nullptr,
          *radius = nullptr;
    Photon* photons = nullptr;  // room for at least the count of the last reserve_photons

    void resize(size_t sample_count);    // (merge_grid.cpp)
    void reserve_photons(size_t count);  // (merge_grid.cpp)

private:
    std::vector<float> values_;
    std::vector<Photon> photon_memory_;
};

}  // namespace cierzo
