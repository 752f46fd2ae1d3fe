#pragma once
// A path the test program removes (with everything under it) when it ends: for the one
// scratch folder a test file's tests share under the system's temporary folder.

#include <filesystem>
#include <system_error>

namespace cierzo::test {

class RemovedAtExit {
public:
    explicit RemovedAtExit(std::filesystem::path path) : path_(std::move(path)) {}
    ~RemovedAtExit() {
        std::error_code ignored;  // (nothing to remove if no test wrote there)
        std::filesystem::remove_all(path_, ignored);
    }
    RemovedAtExit(const RemovedAtExit&) = delete;
    RemovedAtExit& operator=(const RemovedAtExit&) = delete;

private:
    std::filesystem::path path_;
};

}  // namespace cierzo::test
