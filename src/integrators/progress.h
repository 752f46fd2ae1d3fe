// The progress line of a render on stderr: percent done, elapsed time, ETA and Mrays/s,
// printed every half second by a thread of its own while the render runs.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <thread>

namespace cierzo {

class Progress {
public:
    // `total`: the units of the whole render; nothing is printed unless `enabled`.
    Progress(bool enabled, size_t total);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    void units_done(size_t units, uint64_t rays) {
        rays_.fetch_add(rays, std::memory_order_relaxed);
        done_.fetch_add(units, std::memory_order_relaxed);
    }
    // Prints the last line (with a newline) and ends the thread.
    void stop();

private:
    void run();
    void print(bool last);

    bool enabled_;
    size_t total_;
    std::atomic<uint64_t> rays_{0};
    std::atomic<size_t> done_{0};
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    std::mutex mutex_;
    std::condition_variable cv_;
    bool stopping_ = false;
    std::thread thread_;
};

}  // namespace cierzo
