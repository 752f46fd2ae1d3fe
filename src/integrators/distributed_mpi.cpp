// The world under MPI (Open MPI or any MPI-3 library): point-to-point byte messages polled
// with MPI_Iprobe, so no rank ever blocks inside MPI while it has work (a blocked MPI call
// spins a core in most MPI libraries). Only the calling process's main thread calls MPI
// (MPI_THREAD_FUNNELED): the render threads never do.
#include "integrators/distributed.h"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <mpi.h>
#include <unistd.h>

namespace cierzo::mpi {

namespace {

World g_world;
bool g_started = false;

bool launched_by_mpi() {
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE", "PMI_RANK"})
        if (std::getenv(v)) return true;
    return false;
}

void check(int code, const char* what) {
    if (code == MPI_SUCCESS) return;
    char text[MPI_MAX_ERROR_STRING] = {};
    int length = 0;
    MPI_Error_string(code, text, &length);
    throw std::runtime_error(std::string(what) + " failed: " + text);
}

}  // namespace

bool built_with_mpi() { return true; }

void init(int* argc, char*** argv) {
    if (!launched_by_mpi()) return;
    int provided = 0;
    check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    if (provided < MPI_THREAD_FUNNELED) {
        std::fprintf(stderr, "cierzo: the MPI library gives no MPI_THREAD_FUNNELED support\n");
        MPI_Abort(MPI_COMM_WORLD, 2);
    }
    g_started = true;
    // Errors come back as codes (turned into exceptions), not as a silent abort
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_world.rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_world.size);
}

void finalize() {
    if (g_started) MPI_Finalize();
    g_started = false;
}

void abort(int code) {
    std::fflush(stderr);
    if (g_started) MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

const World& world() { return g_world; }

std::string host_name() {
    char name[256] = {};
    if (gethostname(name, sizeof(name) - 1) != 0) return "unknown";
    return name;
}

void send(int dest, int tag, const void* data, size_t bytes) {
    if (bytes > size_t(INT32_MAX)) throw std::length_error("MPI message of more than 2 GiB");
    check(MPI_Send(data, int(bytes), MPI_BYTE, dest, tag, MPI_COMM_WORLD), "MPI_Send");
}

std::optional<Message> try_receive(int tag, int source) {
    int flag = 0;
    MPI_Status status;
    check(MPI_Iprobe(source < 0 ? MPI_ANY_SOURCE : source, tag, MPI_COMM_WORLD, &flag, &status),
          "MPI_Iprobe");
    if (!flag) return std::nullopt;
    int count = 0;
    MPI_Get_count(&status, MPI_BYTE, &count);
    Message m;
    m.source = status.MPI_SOURCE;
    m.bytes.resize(size_t(count));
    check(MPI_Recv(m.bytes.data(), count, MPI_BYTE, status.MPI_SOURCE, tag, MPI_COMM_WORLD,
                   MPI_STATUS_IGNORE),
          "MPI_Recv");
    return m;
}

std::vector<std::vector<char>> gather(const void* data, size_t bytes) {
    std::vector<char> all(g_world.rank == 0 ? bytes * size_t(g_world.size) : 0);
    check(MPI_Gather(data, int(bytes), MPI_BYTE, all.data(), int(bytes), MPI_BYTE, 0,
                     MPI_COMM_WORLD),
          "MPI_Gather");
    std::vector<std::vector<char>> out;
    for (int r = 0; g_world.rank == 0 && r < g_world.size; ++r)
        out.emplace_back(all.begin() + ptrdiff_t(bytes) * r, all.begin() + ptrdiff_t(bytes) * (r + 1));
    return out;
}

}  // namespace cierzo::mpi
