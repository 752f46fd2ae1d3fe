#pragma once
// A test program's scratch folder and the small file helpers its tests share.

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <system_error>

#include "core/error.h"
#include "support/removed_at_exit.h"

namespace cierzo::test {

// TMP/cierzo-test-NAME-PID, made on first use and removed with everything in it when the
// program ends (one per test program: the first call's name is kept).
inline const std::filesystem::path& scratch(const std::string& name) {
    static const std::filesystem::path dir =
        std::filesystem::temp_directory_path() /
        ("cierzo-test-" + name + "-" + std::to_string(::getpid()));
    static const RemovedAtExit cleanup(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

// A FIFO (named pipe) at `path`, made anew.
inline std::filesystem::path make_fifo(const std::filesystem::path& path) {
    std::filesystem::remove(path);
    if (::mkfifo(path.c_str(), 0600) != 0)
        throw std::system_error(errno, std::generic_category(), "mkfifo " + path.string());
    return path;
}

// The message of the InputError that f throws, or "" if it throws none.
inline std::string refusal_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

// refusal_of for a call that must refuse the FIFO `fifo` without opening it. Should the call
// still run after 10 s (waiting in the open for a writer), the FIFO is given writers that
// close at once until it ends, so that the test fails rather than hangs: "(waited on the
// FIFO)" is returned then.
inline std::string refusal_without_opening(const std::filesystem::path& fifo,
                                           const std::function<void()>& f) {
    std::future<std::string> refusal =
        std::async(std::launch::async, [&] { return refusal_of(f); });
    if (refusal.wait_for(std::chrono::seconds(10)) == std::future_status::ready)
        return refusal.get();
    while (refusal.wait_for(std::chrono::milliseconds(100)) != std::future_status::ready) {
        const int writer = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
        if (writer >= 0) ::close(writer);
    }
    refusal.get();
    return "(waited on the FIFO)";
}

}  // namespace cierzo::test
