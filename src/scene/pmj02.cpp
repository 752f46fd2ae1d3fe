#include "pmj02.h"

#include <tbb/parallel_for.h>

#include <bit>
#include <mutex>

#include "kernels/settings.h"

namespace cierzo {
namespace {

// The generator's own random numbers (a 64-bit LCG's high half): fixed, so that the tables
// are the same on every machine.
struct Lcg {
    uint64_t state;
    uint32_t next() {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return uint32_t(state >> 32);
    }
    uint32_t below(uint32_t n) { return uint32_t((uint64_t(next()) * n) >> 32); }
};

// Points in 32-bit fixed point, and which elementary intervals of 2^m cells the points so
// far occupy: shape a has 2^a columns and 2^(m-a) rows.
class Pmj02 {
public:
    explicit Pmj02(uint32_t seed) : rng_{uint64_t(seed) * 0x9e3779b97f4a7c15ull + 1u} {}

    bool generate(uint32_t count) {
        x_.push_back(rng_.next());
        y_.push_back(rng_.next());
        // From n² points to 2n² (each new point in the sub-square of its old point's cell
        // diagonally opposite the old point), then to 4n² (the two sub-squares left)
        for (uint32_t n_log = 0;; ++n_log) {
            const uint32_t n2 = 1u << (2 * n_log);
            if (n2 >= count) return true;
            start_level(2 * n_log + 1);
            for (uint32_t s = 0; s < n2; ++s)
                if (!place_beside(s, n_log, true, true)) return false;
            if (2 * n2 >= count) return true;
            start_level(2 * n_log + 2);
            std::vector<uint8_t> flip_x(n2);
            for (uint32_t s = 0; s < n2; ++s) {
                flip_x[s] = uint8_t(rng_.next() >> 31);
                if (!place_beside(s, n_log, flip_x[s], !flip_x[s])) return false;
            }
            for (uint32_t s = 0; s < n2; ++s)
                if (!place_beside(s, n_log, !flip_x[s], flip_x[s])) return false;
        }
    }

    std::vector<uint32_t> packed(uint32_t count) const {
        std::vector<uint32_t> t(count);
        for (uint32_t i = 0; i < count; ++i) t[i] = (x_[i] >> 16) | (y_[i] & 0xffff0000u);
        return t;
    }

private:
    uint32_t cell(uint32_t x, uint32_t y, uint32_t a) const {
        const uint32_t col = a == 0 ? 0u : x >> (32 - a);
        const uint32_t row = a == m_ ? 0u : y >> (32 - (m_ - a));
        return (row << a) | col;
    }
    bool free_at(uint32_t x, uint32_t y) const {
        for (uint32_t a = 0; a <= m_; ++a)
            if (occupied_[a][cell(x, y, a)]) return false;
        return true;
    }
    void occupy(uint32_t x, uint32_t y) {
        for (uint32_t a = 0; a <= m_; ++a) occupied_[a][cell(x, y, a)] = 1;
    }
    void start_level(uint32_t m) {
        m_ = m;
        occupied_.assign(m + 1, std::vector<uint8_t>(size_t(1) << m, 0));
        for (size_t i = 0; i < x_.size(); ++i) occupy(x_[i], y_[i]);
    }

    // A new point in old point s's cell of the 2^n_log grid, in the sub-square across from
    // s's in x (flip_x) and/or y, in elementary intervals no point occupies yet: a random
    // free column and a free row of the finest 1D strata inside the sub-square, then a random
    // jitter inside them, until every shape is free.
    bool place_beside(uint32_t s, uint32_t n_log, bool flip_x, bool flip_y) {
        const uint32_t cell_mask = n_log == 0 ? 0u : ~(0xffffffffu >> n_log);
        const uint32_t half = 1u << (31 - n_log);
        const uint32_t bx = (x_[s] & cell_mask) | ((x_[s] & half) ^ (flip_x ? half : 0u));
        const uint32_t by = (y_[s] & cell_mask) | ((y_[s] & half) ^ (flip_y ? half : 0u));
        const uint32_t strata = 1u << (m_ - n_log - 1);  // finest 1D strata in a sub-square
        columns_.clear(), rows_.clear();
        for (uint32_t k = 0; k < strata; ++k) {
            const uint32_t c = (bx >> (32 - m_)) + k, r = (by >> (32 - m_)) + k;
            if (!occupied_[m_][c]) columns_.push_back(c);
            if (!occupied_[0][r]) rows_.push_back(r);
        }
        if (columns_.empty() || rows_.empty()) return false;
        const uint32_t jitter = 0xffffffffu >> m_;
        for (int attempt = 0; attempt < 1 << 20; ++attempt) {
            const uint32_t x = (columns_[rng_.below(uint32_t(columns_.size()))] << (32 - m_)) |
                               (rng_.next() & jitter);
            const uint32_t y =
                (rows_[rng_.below(uint32_t(rows_.size()))] << (32 - m_)) | (rng_.next() & jitter);
            if (free_at(x, y)) {
                occupy(x, y);
                x_.push_back(x), y_.push_back(y);
                return true;
            }
        }
        return false;
    }

    Lcg rng_;
    uint32_t m_ = 0;
    std::vector<uint32_t> x_, y_;
    std::vector<std::vector<uint8_t>> occupied_;
    std::vector<uint32_t> columns_, rows_;
};

}  // namespace

std::vector<uint32_t> make_pmj02_table(uint32_t count, uint32_t seed) {
    // A generator that runs out of room (none has for the seeds used) starts over from the
    // next seed, so the table is still a function of `seed` alone.
    for (uint32_t attempt = 0;; ++attempt) {
        Pmj02 g(seed + attempt * 0x632be5abu);
        if (g.generate(count)) return g.packed(count);
    }
}

const uint32_t* pmj02_tables() {
    static std::vector<uint32_t> tables;
    static std::once_flag made;
    std::call_once(made, [] {
        tables.resize(size_t(kPmj02Tables) * kPmj02Points);
        tbb::parallel_for(uint32_t(0), kPmj02Tables, [](uint32_t t) {
            const std::vector<uint32_t> one = make_pmj02_table(kPmj02Points, t + 1u);
            std::copy(one.begin(), one.end(), tables.begin() + size_t(t) * kPmj02Points);
        });
    });
    return tables.data();
}

}  // namespace cierzo
