#pragma once
// Huge files that cost nothing: some bytes, then a hole (ftruncate) up to tens of GiB, for the
// tests that a reader looks only at what a file's header declares; and what reading one cost.

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string_view>

namespace cierzo::test {

constexpr uint64_t k30GiB = uint64_t(30) << 30;

// Writes `head` to `path`, then makes the file `size` bytes long with a hole after it. False
// when the file system cannot hold the hole without storing it (more than a MiB of blocks
// more than the head's), the file then removed: the caller skips its test.
inline bool make_sparse_file(const std::filesystem::path& path, std::string_view head,
                             uint64_t size) {
    {
        std::ofstream out(path, std::ios::binary);
        out.write(head.data(), std::streamsize(head.size()));
        if (!out) return false;
    }
    struct stat status = {};
    const bool sparse = ::truncate(path.c_str(), off_t(size)) == 0 &&
                        ::stat(path.c_str(), &status) == 0 && uint64_t(status.st_size) == size &&
                        uint64_t(status.st_blocks) * 512 < head.size() + (uint64_t(1) << 20);
    if (!sparse) std::filesystem::remove(path);
    return sparse;
}

inline const char* const kNoSparseFiles =
    "the temporary folder's file system cannot make sparse files";

// This process's peak resident memory so far, in bytes (getrusage: ru_maxrss, in KiB on Linux).
inline uint64_t peak_resident_bytes() {
    struct rusage usage = {};
    ::getrusage(RUSAGE_SELF, &usage);
    return uint64_t(usage.ru_maxrss) * 1024;
}

// The wall time and the growth of the peak resident memory since it was made: a reader that
// read a sparse file's hole would take minutes or run out of memory, so a test asserts both
// generously (seconds, not milliseconds; 200 MB, not the few KiB the header takes).
class ReadCost {
public:
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    }
    uint64_t peak_growth_bytes() const { return peak_resident_bytes() - peak_; }

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    uint64_t peak_ = peak_resident_bytes();
};

constexpr double kGenerousSeconds = 10.0;
// (under qemu-user, in a cross build's tests, 1 GiB: the emulator keeps flags of its own for
// every page the program maps, 378 MB for a mapped 30 GiB file, which is qemu's memory, not
// the reader's; reading the file would still cost 30 GiB)
inline const uint64_t kGenerousGrowth =
    std::string_view(CIERZO_TEST_EMULATOR).empty() ? uint64_t(200) << 20 : uint64_t(1) << 30;

}  // namespace cierzo::test
