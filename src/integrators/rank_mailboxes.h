// A rank's mailboxes (rank_protocol.cpp): the link to the other ranks (and rank 0's to itself),
// the units a rank holds with the work for its render threads, and what they leave to send.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "integrators/distributed.h"
#include "integrators/film.h"
#include "integrators/render_types.h"
#include "integrators/scheduler.h"

namespace cierzo::rank {

// Messages to another rank go through MPI; to itself (rank 0 is its own dealer) through a
// queue here, in order. Arrived messages are taken in once per turn of a loop (pump: one
// probe for any tag, however many kinds the loop then reads) into queues by tag.
class Link {
public:
    explicit Link(int me) : me_(me) {}
    void send(int dest, int tag, std::vector<char> bytes) {
        if (dest == me_)
            inbox_[tag].push_back({me_, std::move(bytes), tag});
        else
            mpi::send(dest, tag, std::move(bytes));
    }
    void pump() {
        while (std::optional<mpi::Message> m = mpi::try_receive(-1)) {
            const int tag = m->tag;
            inbox_[tag].push_back(std::move(*m));
        }
    }
    // The next message of this tag taken in (from `source`, if not -1; in arrival order).
    bool has(int tag) const {
        auto it = inbox_.find(tag);
        return it != inbox_.end() && !it->second.empty();
    }
    std::optional<mpi::Message> receive(int tag, int source = -1) {
        auto it = inbox_.find(tag);
        if (it == inbox_.end()) return std::nullopt;
        std::deque<mpi::Message>& q = it->second;
        for (auto m = q.begin(); m != q.end(); ++m) {
            if (source >= 0 && m->source != source) continue;
            mpi::Message out = std::move(*m);
            q.erase(m);
            return out;
        }
        return std::nullopt;
    }

private:
    int me_;
    std::map<int, std::deque<mpi::Message>> inbox_;
};

// The units this rank was given and not yet finished, by pass.
class LocalQueue {
public:
    void push(const std::vector<Unit>& units) {
        std::lock_guard lock(mutex_);
        for (const Unit& u : units) {
            units_.push_back(u);
            ++held_[u.pass];
        }
        cv_.notify_all();
    }
    // Work for the next free render thread, before any unit: a band's work (a pass
    // announced, units' sums from another rank), so that the main thread only deals with
    // messages. pop() gives it as a unit of tile kTask, and task() then hands it over.
    static constexpr int32_t kTask = -1;
    void push_task(std::function<void()> task) {
        std::lock_guard lock(mutex_);
        tasks_.push_back(std::move(task));
        cv_.notify_one();
    }
    std::optional<Unit> pop(std::function<void()>& task) {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return !units_.empty() || !tasks_.empty() || over_; });
        if (over_) return std::nullopt;
        if (!tasks_.empty()) {
            task = std::move(tasks_.front());
            tasks_.pop_front();
            return Unit{kTask, 0, 0, 0};
        }
        Unit u = units_.front();
        units_.pop_front();
        return u;
    }
    void finished(int32_t pass) {
        std::lock_guard lock(mutex_);
        if (--held_[pass] == 0) held_.erase(pass);
        if (size() < low_) done_cv_.notify_all();
    }
    // Waits until fewer than `low` units are held, wake() is called or `timeout` passes.
    void wait(size_t low, std::chrono::microseconds timeout) {
        std::unique_lock lock(mutex_);
        low_ = low;
        done_cv_.wait_for(lock, timeout, [&] { return size() < low || over_ || woken_; });
        woken_ = false;
    }
    // Wakes the main thread's wait (something to send: a band's report, units' sums).
    void wake() {
        std::lock_guard lock(mutex_);
        woken_ = true;
        done_cv_.notify_all();
    }
    void set_over() {
        std::lock_guard lock(mutex_);
        over_ = true;
        units_.clear();
        cv_.notify_all();
        done_cv_.notify_all();
    }
    size_t pending() {
        std::lock_guard lock(mutex_);
        return size();
    }
    bool holds(int32_t pass) {
        std::lock_guard lock(mutex_);
        return held_.count(pass) != 0;
    }

private:
    size_t size() const {
        size_t n = 0;
        for (const auto& [pass, count] : held_) n += size_t(count);
        return n;
    }
    std::mutex mutex_;
    std::condition_variable cv_, done_cv_;
    std::deque<Unit> units_;
    std::deque<std::function<void()>> tasks_;
    std::map<int32_t, int64_t> held_;  // queued or being rendered
    size_t low_ = 0;
    bool over_ = false, woken_ = false;
};

// What the render threads leave for the main thread to send: units of other ranks' tiles,
// and splats by pass and owner (with the rays of light batches, by pass).
struct Outbox {
    std::mutex mutex;
    std::map<int, std::vector<char>> results;  // by owner: a Results message
    std::map<int32_t, std::vector<std::vector<Splat>>> splats;
    std::map<int32_t, RayCounts> light_rays;
};

}  // namespace cierzo::rank
