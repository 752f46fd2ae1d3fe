// Rank 0's hand-out of units and its count of passes (see unit_dealer.h).
#include "integrators/unit_dealer.h"

#include <algorithm>
#include <stdexcept>

namespace cierzo {

UnitDealer::UnitDealer(const TileBands& bands, size_t light_units, std::vector<int64_t> bounds,
                       const RenderOptions& options, Clock::time_point start, Progress& progress,
                       const std::vector<uint8_t>& pending, bool guided)
    : bands_(bands),
      light_units_(light_units),
      bounds_(std::move(bounds)),
      options_(options),
      start_(start),
      progress_(progress),
      pending_(pending),
      guided_(guided),
      reported_(size_t(bands.ranks()), 0) {
    passes_ = int32_t(bounds_.size()) - 1;
    if (passes_ <= 0) {
        stopping_ = true;
        return;
    }
    open(deals_[0], 0);
    if (passes_ > 1) open(deals_[1], 1);
}

void UnitDealer::open(Deal& d, int32_t pass) {
    const int ranks = bands_.ranks();
    d.pass = pass;
    d.lo.resize(size_t(ranks)), d.hi.resize(size_t(ranks));
    d.left = light_units_;
    for (int r = 0; r < ranks; ++r) {
        d.lo[size_t(r)] = bands_.first(r), d.hi[size_t(r)] = bands_.first(r + 1);
        d.left += bands_.count(r);
    }
    d.light = 0, d.victim = 0;
    if (pass == 0 && !pending_.empty()) {
        // (tiles a checkpoint holds are not handed out again; take_own and take_other skip
        // them, and here they are not counted as left)
        for (size_t k = 0; k < bands_.tiles() && k < pending_.size(); ++k) d.left -= pending_[k];
    }
}

UnitDealer::Deal* UnitDealer::deal(int32_t pass) {
    if (pass >= passes_ || pass < frontier_ || pass > frontier_ + 1) return nullptr;
    Deal& d = deals_[pass & 1];
    return d.pass == pass ? &d : nullptr;
}

Unit UnitDealer::unit(const Deal& d, size_t image_tile) const {
    return Unit{int32_t(light_units_ + image_tile), d.pass, bounds_[size_t(d.pass)],
                bounds_[size_t(d.pass) + 1]};
}

std::optional<Unit> UnitDealer::take_light(Deal& d) {
    if (d.light >= light_units_) return std::nullopt;
    --d.left;
    return Unit{int32_t(d.light++), d.pass, bounds_[size_t(d.pass)], bounds_[size_t(d.pass) + 1]};
}

std::optional<Unit> UnitDealer::take_own(Deal& d, int rank) {
    size_t& lo = d.lo[size_t(rank)];
    const size_t hi = d.hi[size_t(rank)];
    const bool skip = d.pass == 0 && !pending_.empty();
    while (lo < hi && skip && pending_[lo]) ++lo;
    if (lo >= hi) return std::nullopt;
    --d.left;
    return unit(d, lo++);
}

std::optional<Unit> UnitDealer::take_other(Deal& d) {
    // From the end of a band with tiles left (a round robin from where the last one was
    // found: each band is looked at once per pass after it runs out)
    const size_t ranks = d.lo.size();
    const bool skip = d.pass == 0 && !pending_.empty();
    for (size_t n = 0; n < ranks; ++n) {
        const size_t r = (d.victim + n) % ranks;
        size_t& hi = d.hi[r];
        while (hi > d.lo[r] && skip && pending_[hi - 1]) --hi;
        if (hi > d.lo[r]) {
            d.victim = r;
            --d.left;
            return unit(d, --hi);
        }
    }
    return std::nullopt;
}

std::vector<Unit> UnitDealer::grant(int rank, size_t n) {
    std::vector<Unit> out;
    if (stopping_) return out;
    // (at most a rank's share of the two passes that can be handed out: with many ranks,
    // the first to ask would otherwise take the others' tiles)
    const size_t units = light_units_ + bands_.tiles();
    n = std::min(n, std::max<size_t>(1, 2 * units / size_t(bands_.ranks())));
    Deal* now = deal(frontier_);
    // (a guided render's pass after a training waits for it: path_guide.h)
    Deal* next = guided_ && frontier_ + 1 < passes_ &&
                         PathGuide::trains_before(bounds_[size_t(frontier_) + 1])
                     ? nullptr
                     : deal(frontier_ + 1);
    // Light batches, own tiles, others' tiles; each of the pass in progress, then the next
    enum Take { kLight, kOwn, kOther };
    for (Take take : {kLight, kOwn, kOther})
        for (Deal* d : {now, next})
            while (d && out.size() < n) {
                std::optional<Unit> u = take == kLight ? take_light(*d)
                                        : take == kOwn ? take_own(*d, rank)
                                                       : take_other(*d);
                if (!u) break;
                out.push_back(*u);
            }
    granted_ += out.size();
    return out;
}

int32_t UnitDealer::granted_through() const {
    int32_t through = frontier_ - 1;
    for (int32_t p = frontier_; p < passes_ && p <= frontier_ + 1; ++p) {
        const Deal& d = deals_[p & 1];
        if (d.pass != p || d.left > 0) break;
        through = p;
    }
    return through;
}

void UnitDealer::report(int rank, const PassReport& r) {
    if (stopping_) return;
    if (rank < 0 || rank >= bands_.ranks() || r.pass != frontier_ || reported_[size_t(rank)])
        throw std::runtime_error("rank " + std::to_string(rank) + " reported pass " +
                                 std::to_string(r.pass) + " while pass " +
                                 std::to_string(frontier_) + " is in progress");
    reported_[size_t(rank)] = 1;
    error_.merge(r.error);
    pass_rays_ += r.rays;
    progress_.units_done(bands_.count(rank) + (rank == 0 ? light_units_ : 0), r.rays.total());
    if (++reports_ == bands_.ranks()) end_pass();
}

void UnitDealer::end_pass() {
    rays_ += pass_rays_;
    const ErrorSum error = error_;
    pass_rays_ = {}, error_ = {}, reports_ = 0;
    std::fill(reported_.begin(), reported_.end(), 0);
    pending_.clear();  // (the first pass's)
    ++frontier_;
    if (frontier_ + 1 < passes_) open(deals_[(frontier_ + 1) & 1], frontier_ + 1);
    if (frontier_ == passes_) {
        stopping_ = true;
        return;
    }
    stopped_by_ = stop_at_pass_end(options_, start_, bounds_[size_t(frontier_)],
                                   [&] { return error.value(); });
    if (!stopped_by_.empty()) stopping_ = true;
}

void UnitDealer::interrupt() {
    if (stopping_ || frontier_ == 0) return;
    stopped_by_ = "interrupted";
    stopping_ = true;
}

}  // namespace cierzo
