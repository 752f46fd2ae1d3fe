// A test that runs cierzo's programs end to end: a scratch folder of its own (removed after
// the test), files written into it, and a program run with a time limit whose exit code,
// standard output and standard error are kept.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <string>
#include <system_error>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include "support/emulator.h"

namespace cierzo::test {

inline std::string read_file(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// A path quoted for the shell. (Built by appending: GCC 12 warns falsely (-Wrestrict) about
// "'" + std::string.)
inline std::string quote(const std::filesystem::path& p) {
    std::string q = "'";
    q += p.string();
    q += '\'';
    return q;
}

struct Outcome {
    int exit_code = -1;  // -1: did not exit normally (crash, signal)
    std::string err;
    std::string out;  // standard output
    double seconds = 0.0;
};

class ProgramTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = std::filesystem::temp_directory_path() /
               ("cierzo_test_" + std::string(info->test_suite_name()) + "_" +
                std::to_string(getpid()) + "_" + info->name());
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }

    std::filesystem::path write(const std::string& name, const std::string& text) {
        const std::filesystem::path p = dir_ / name;
        std::ofstream(p, std::ios::binary) << text;
        return p;
    }

    // `cierzo render ARGS` (or another subcommand) with a time limit, so a refused render
    // can never hang the suite.
    Outcome run(const std::string& args, const char* subcommand = "render") {
        return run_program("cierzo", std::string(subcommand) + " " + args);
    }

    // One of the build's programs (e.g. "cierzo-tonemap") with ARGS, as `run` runs cierzo.
    Outcome run_program(const std::string& name, const std::string& args) {
        const std::filesystem::path err = dir_ / "stderr.txt", out = dir_ / "stdout.txt";
        const std::string program = emulated(quote(CIERZO_BINARY_DIR "/" + name));
        const std::string cmd =
            "timeout 120 " + program + " " + args + " >" + quote(out) + " 2>" + quote(err);
        const auto start = std::chrono::steady_clock::now();
        const int status = std::system(cmd.c_str());
        Outcome r;
        r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (status != -1 && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
        r.err = read_file(err);
        r.out = read_file(out);
        std::filesystem::remove(err), std::filesystem::remove(out);
        return r;
    }

    // Files in the test folder other than the given ones (e.g. a leftover temporary file).
    std::vector<std::string> other_files(std::initializer_list<std::string> expected) {
        std::vector<std::string> others;
        for (const auto& e : std::filesystem::directory_iterator(dir_)) {
            const std::string n = e.path().filename().string();
            if (std::find(expected.begin(), expected.end(), n) == expected.end())
                others.push_back(n);
        }
        return others;
    }

    std::filesystem::path dir_;
};

}  // namespace cierzo::test
