#pragma once
// A test program's scratch folder and the small file helpers its tests share.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

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

// The message of the InputError that f throws, or "" if it throws none.
inline std::string refusal_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace cierzo::test
