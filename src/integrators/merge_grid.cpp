#include "integrators/merge_grid.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>

namespace cierzo {

namespace {

// A cell's coordinate along one axis, ⌊v⌋ (clamped far beyond any scene: a point that far
// out shares its cell with its neighbours, which the distance test sorts out). (Truncated,
// then one less below zero: std::floor is a call's worth of code on the baseline x86-64,
// which has no instruction for it, and this runs three times a query.)
int32_t cell_of(double v) {
    const double c = std::clamp(v, -1.0e9, 1.0e9);
    const int32_t i = int32_t(c);
    return i - int32_t(c < double(i));
}

// A block of cells' hash, from its coordinates' products with the three multipliers.
uint32_t hash_mixed(uint32_t h) {
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    return h;
}
constexpr uint32_t kHashX = 73856093u, kHashY = 19349663u, kHashZ = 83492791u;

// A cell's bucket in a table of mask + 1 ≥ 8 buckets: the hash of its 2 × 2 × 2 block of
// cells, with the parities of its three coordinates as the low 3 bits. The 8 cells a query
// reads are the 8 parities, so they never share a bucket (a query needs no test for a
// bucket named twice).
uint32_t parity_bits(int32_t ix, int32_t iy, int32_t iz) {
    return uint32_t(ix & 1) | uint32_t(iy & 1) << 1 | uint32_t(iz & 1) << 2;
}
// (from the block's products, summed by xor, and the cell's parities: a query forms the
// products of its 8 cells' blocks from each axis's two)
uint32_t bucket_in_block(uint32_t block_products, uint32_t parity, uint32_t mask) {
    return (hash_mixed(block_products) << 3 | parity) & mask;
}
uint32_t bucket_of(int32_t ix, int32_t iy, int32_t iz, uint32_t mask) {
    return bucket_in_block(
        uint32_t(ix >> 1) * kHashX ^ uint32_t(iy >> 1) * kHashY ^ uint32_t(iz >> 1) * kHashZ,
        parity_bits(ix, iy, iz), mask);
}

}  // namespace

void MergeGrid::build(const Photon* points_in, size_t count, const float* radius, size_t sets) {
    const std::span<const Photon> points(points_in, count);
    inverse_cell_.resize(sets);
    for (size_t k = 0; k < sets; ++k) {
        const double r = radius[k];
        inverse_cell_[k] = r > 0.0 && std::isfinite(r) ? 0.5 / r : 0.0;
    }
    // Each set's table: a power of two at least twice its points, and at least 8 (bucket_of)
    scratch_.assign(sets, 0u);
    for (const Photon& p : points)
        if (p.set < sets) ++scratch_[p.set];
    table_.resize(2 * sets);
    uint32_t buckets = 0;
    for (size_t k = 0; k < sets; ++k) {
        const uint32_t size = std::max(std::bit_ceil(std::max(scratch_[k], 1u) * 2u), 8u);
        table_[2 * k] = buckets, table_[2 * k + 1] = size - 1u;
        buckets += size;
    }
    begin_.assign(size_t(buckets) + 1, 0);
    scratch_.resize(points.size());
    for (size_t v = 0; v < points.size(); ++v) {
        const Photon& p = points[v];
        const double inv = p.set < sets ? inverse_cell_[p.set] : 0.0;
        // (a point that is not finite is in no cell)
        if (inv == 0.0 || !std::isfinite(p.p[0]) || !std::isfinite(p.p[1]) ||
            !std::isfinite(p.p[2])) {
            scratch_[v] = ~0u;
            continue;
        }
        const uint32_t b =
            table_[2 * p.set] + bucket_of(cell_of(p.p[0] * inv), cell_of(p.p[1] * inv),
                                          cell_of(p.p[2] * inv), table_[2 * p.set + 1]);
        scratch_[v] = b;
        ++begin_[size_t(b) + 1];
    }
    for (uint32_t b = 0; b < buckets; ++b) begin_[b + 1] += begin_[b];
    sorted_.resize(size_t(begin_[buckets]));
    // (begin_[b] is advanced past each point placed, then restored)
    for (size_t v = 0; v < points.size(); ++v)
        if (scratch_[v] != ~0u) sorted_[size_t(begin_[scratch_[v]]++)] = points[v];
    for (uint32_t b = buckets; b > 0; --b) begin_[b] = begin_[b - 1];
    begin_[0] = 0;
    photons_ = sorted_.data();
}

void MergeTable::resize(size_t sample_count) {
    samples = int32_t(sample_count);
    values_.resize(5 * sample_count);
    float* v = values_.data();
    vm_weight = v, vc_weight = v + sample_count, normalization = v + 2 * sample_count;
    radius2 = v + 3 * sample_count, radius = v + 4 * sample_count;
}

void MergeTable::reserve_photons(size_t count) {
    if (photon_memory_.size() < count) photon_memory_.resize(count);
    photons = photon_memory_.data();
}

int MergeGrid::cells(float x, float y, float z, int32_t set, Range out[8]) const {
    if (set < 0 || size_t(set) >= inverse_cell_.size() || inverse_cell_[size_t(set)] == 0.0 ||
        !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        return 0;
    const double inv = inverse_cell_[size_t(set)];
    const uint32_t first = table_[2 * size_t(set)], mask = table_[2 * size_t(set) + 1];
    // The 2 × 2 × 2 cells around the cell corner nearest the position
    const int32_t ix = cell_of(x * inv - 0.5), iy = cell_of(y * inv - 0.5),
                  iz = cell_of(z * inv - 0.5);
    // (bucket_of the 8 cells, from each axis's two blocks' products)
    const uint32_t hx[2] = {uint32_t(ix >> 1) * kHashX, uint32_t((ix + 1) >> 1) * kHashX};
    const uint32_t hy[2] = {uint32_t(iy >> 1) * kHashY, uint32_t((iy + 1) >> 1) * kHashY};
    const uint32_t hz[2] = {uint32_t(iz >> 1) * kHashZ, uint32_t((iz + 1) >> 1) * kHashZ};
    const uint32_t parity = parity_bits(ix, iy, iz);
    // The buckets that hold points, kept without a branch: half of them are empty, at
    // random, which a branch would mispredict (measured: this query was a quarter of vcm's
    // time on caustic.json)
    int count = 0;
    for (int k = 0; k < 8; ++k) {
        // (cell k's parities: the corner's, flipped along the axes k steps along)
        const uint32_t b = first + bucket_in_block(hx[k & 1] ^ hy[(k >> 1) & 1] ^ hz[k >> 2],
                                                   parity ^ uint32_t(k), mask);
        const Range r{begin_[b], begin_[b + 1]};
        out[count] = r;
        count += int(r.begin != r.end);
    }
    return count;
}

}  // namespace cierzo
