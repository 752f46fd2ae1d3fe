// Progressive multi-jittered (0,2) sequences (Christensen, Kensler and Kilpatrick,
// "Progressive Multi-Jittered Sample Sequences", EGSR 2018): the tables of the pmj02
// sampler (kernels/sampler.h).
#pragma once

#include <cstdint>
#include <vector>

namespace cierzo {

// One table of `count` (a power of two) points, each x | y << 16 in 16-bit fixed point, made
// from `seed` alone: every prefix of 2^k points, and every aligned block of 2^k, is a
// (0,k,2)-net (one point in each elementary interval of area 2^-k), and the points of each
// prefix of 4^k are also jittered in a 2^k × 2^k grid.
std::vector<uint32_t> make_pmj02_table(uint32_t count, uint32_t seed);

// The kPmj02Tables tables of kPmj02Points the sampler reads, made once per process (in
// parallel) on first use.
const uint32_t* pmj02_tables();

}  // namespace cierzo
