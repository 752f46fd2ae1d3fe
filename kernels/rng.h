// Counter-based random numbers: every number is a hash of (seed, pixel, sample, bounce,
// purpose), never state carried by a thread, so an image does not depend on how the work
// was split and both integrators draw the same numbers for the same path vertex.
#pragma once

#include "lanes.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// What a random number is for at one path vertex. Each gets its own hash stream.
enum class Purpose : uint32_t {
    kPixelX = 0,  // jitter inside the pixel (bounce 0 only)
    kPixelY = 1,
    kLobe = 2,        // Russian roulette: which lobe, or death
    kDirection1 = 3,  // the two numbers that sample a direction in the chosen lobe
    kDirection2 = 4,
    kEmitterPick = 5,  // next-event estimation: which emitter (and, rehashed, its alias slot)
    kEmitter1 = 6,     // the two numbers that sample a point or direction on it
    kEmitter2 = 7,
};
inline constexpr uint32_t kPurposesPerBounce = 8;

// A 32-bit integer hash with low bias ("lowbias32", C. Wellons, hash-prospector).
template <class U>
inline U hash32(U x) {
    x ^= x >> 16;
    x *= splat<U, 0x21f0aaadu>();
    x ^= x >> 15;
    x *= splat<U, 0xd35a2d97u>();
    x ^= x >> 15;
    return x;
}

// The key of one path: (seed, pixel, sample) hashed once when the path starts.
template <class U>
inline U path_key(uint32_t seed, const U& pixel, const U& sample) {
    const U s(hash32(seed ^ 0x6a09e667u));
    return hash32(hash32(pixel ^ s) + sample * U(0x9e3779b9u));
}

// The key of the path from the lights traced beside camera path `key` (light tracing: one
// light path per camera path, keyed by the same (seed, pixel, sample)).
template <class U>
inline U light_path_key(const U& key) {
    return hash32(key ^ splat<U, 0x2545f491u>());
}

// The 32 random bits of (path, bounce, purpose), which every uniform below derives from.
template <class T>
inline U32<T> purpose_bits(const U32<T>& key, const U32<T>& bounce, Purpose purpose) {
    using U = U32<T>;
    const U counter = bounce * U(kPurposesPerBounce) + U(uint32_t(purpose) + 1u);
    return hash32(key ^ hash32(counter * splat<U, 0x85ebca6bu>()));
}

// A uniform number in [0, 1) with 24 random bits for (path, bounce, purpose).
template <class T>
inline T uniform(const U32<T>& key, const U32<T>& bounce, Purpose purpose) {
    return to_float(purpose_bits<T>(key, bounce, purpose) >> 8) * T(0x1.0p-24f);
}

// Two independent uniforms for one (path, bounce, purpose): the second is the first's hash
// hashed again, for a choice that needs more than 24 bits (an emitter among many, then its
// alias slot).
template <class T>
inline void uniform_pair(const U32<T>& key, const U32<T>& bounce, Purpose purpose, T& u, T& v) {
    using U = U32<T>;
    const U bits = purpose_bits<T>(key, bounce, purpose);
    u = to_float(bits >> 8) * T(0x1.0p-24f);
    v = to_float(hash32(bits ^ splat<U, 0x3c6ef372u>()) >> 8) * T(0x1.0p-24f);
}

// A second uniform for (path, bounce, purpose), independent of uniform()'s: the throughput
// roulette's draw beside the lobe choice (Purpose::kLobe), with no purpose of its own, so the
// numbers of every other decision are those they always were.
template <class T>
inline T second_uniform(const U32<T>& key, const U32<T>& bounce, Purpose purpose) {
    using U = U32<T>;
    const U bits = purpose_bits<T>(key, bounce, purpose);
    return to_float(hash32(bits ^ splat<U, 0x510e527fu>()) >> 8) * T(0x1.0p-24f);
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
