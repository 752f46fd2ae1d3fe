// Atomic file replacement: a uniquely named temporary file in the destination folder is
// written, synced and renamed into place; every failure removes it and names the path.
#include "io/atomic_file.h"

#include "core/error.h"

#include <atomic>
#include <cerrno>
#include <exception>
#include <string>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

namespace cierzo {

namespace fs = std::filesystem;

namespace {

std::atomic<unsigned long> temp_counter{0};

// Longest file-name prefix copied into a temporary name, so that it stays under NAME_MAX.
constexpr size_t kMaxTempStem = 200;

[[noreturn]] void fail(const fs::path& path, const std::string& reason) {
    throw InputError(path.string() + ": cannot write: " + reason);
}

std::string errno_text(int err) { return std::generic_category().message(err); }

// Creates an empty file with a new unique name in `dir` and returns its path.
fs::path create_temp_file(const fs::path& path, const fs::path& dir) {
    const std::string stem = path.filename().string().substr(0, kMaxTempStem);
    for (int attempt = 0; attempt < 100; ++attempt) {
        const fs::path tmp = dir / ("." + stem + ".tmp." + std::to_string(::getpid()) + "." +
                                    std::to_string(temp_counter.fetch_add(1)));
        const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            return tmp;
        }
        if (errno != EEXIST) {
            fail(path, errno_text(errno));
        }
    }
    fail(path, "cannot create a unique temporary file in " + dir.string());
}

void remove_quietly(const fs::path& tmp) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
}

// Flushes the finished temporary file to disk so that the rename never publishes a file
// whose data is still only in the page cache.
void sync_file(const fs::path& path, const fs::path& tmp) {
    const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        fail(path, "temporary file " + tmp.string() + " vanished: " + errno_text(errno));
    }
    const int result = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    if (result != 0) {
        fail(path, errno_text(err));
    }
}

}  // namespace

void write_atomically(const fs::path& path,
                      const std::function<void(const fs::path& tmp)>& write) {
    if (path.empty()) {
        throw InputError("cannot write: empty file name");
    }
    if (!path.has_filename()) {
        fail(path, "not a file name");
    }
    std::error_code ec;
    if (fs::is_directory(fs::status(path, ec))) {
        fail(path, errno_text(EISDIR));
    }
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    const fs::path tmp = create_temp_file(path, dir);
    try {
        write(tmp);
        sync_file(path, tmp);
    } catch (const InputError&) {
        remove_quietly(tmp);
        throw;
    } catch (const std::exception& e) {
        remove_quietly(tmp);
        fail(path, e.what());
    } catch (...) {
        remove_quietly(tmp);
        throw;
    }
    if (::rename(tmp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        remove_quietly(tmp);
        fail(path, errno_text(err));
    }
}

void write_stream_atomically(const fs::path& path,
                             const std::function<void(std::ofstream& out)>& write) {
    write_atomically(path, [&](const fs::path& tmp) {
        errno = 0;
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) {
            fail(path, "cannot open temporary file " + tmp.string() + ": " + errno_text(errno));
        }
        const auto check = [&](const char* what) {
            if (!out) {
                fail(path, errno != 0 ? std::string(what) + ": " + errno_text(errno) : what);
            }
        };
        errno = 0;
        write(out);
        check("write error");
        out.flush();
        check("write error");
        out.close();
        check("error closing the file");
    });
}

}  // namespace cierzo
