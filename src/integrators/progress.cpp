// The progress line (see progress.h).
#include "integrators/progress.h"

#include <algorithm>
#include <cstdio>

namespace cierzo {

Progress::Progress(bool enabled, size_t total) : enabled_(enabled), total_(total) {
    if (enabled_) thread_ = std::thread([this] { run(); });
}

Progress::~Progress() { stop(); }

void Progress::stop() {
    if (!thread_.joinable()) return;
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();
    print(true);
}

void Progress::run() {
    std::unique_lock lock(mutex_);
    while (!cv_.wait_for(lock, std::chrono::milliseconds(500), [&] { return stopping_; }))
        print(false);
}

void Progress::print(bool last) {
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double f = double(done_.load()) / double(std::max<size_t>(total_, 1));
    const double eta = f > 0 ? s * (1.0 - f) / f : 0.0;
    const double mrays = s > 0 ? double(rays_.load()) / s * 1e-6 : 0.0;
    std::fprintf(stderr, "\r%5.1f%%  %6.1f s  ETA %6.1f s  %8.2f Mrays/s%s", 100.0 * f, s, eta,
                 mrays, last ? "\n" : "");
    std::fflush(stderr);
}

}  // namespace cierzo
