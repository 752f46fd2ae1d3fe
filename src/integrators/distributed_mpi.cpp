// The world under MPI (Open MPI or any MPI-3 library): point-to-point byte messages polled
// with MPI_Iprobe, so no rank ever blocks inside MPI while it has work (a blocked MPI call
// spins a core in most MPI libraries). Only the calling process's main thread calls MPI
// (MPI_THREAD_FUNNELED): the render threads never do.
#include "integrators/distributed.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <deque>
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
    while (!progress()) {
    }
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

namespace {

struct Transfer {
    MPI_Request request = MPI_REQUEST_NULL;
    int tag = 0;
    Message message;
};
std::deque<Transfer> g_sends, g_receives;  // in the order started
std::vector<std::vector<char>> g_buffers;  // recycled receive buffers
// Messages sent to and received from each rank (drain)
std::vector<uint64_t> g_sent, g_received;
uint64_t g_bytes_sent = 0;

void tally(std::vector<uint64_t>& counts, int rank) {
    if (counts.size() < size_t(g_world.size)) counts.resize(size_t(g_world.size));
    ++counts[size_t(rank)];
}

}  // namespace

void send(int dest, int tag, std::vector<char> bytes) {
    if (bytes.size() > size_t(INT32_MAX)) throw std::length_error("MPI message of more than 2 GiB");
    tally(g_sent, dest);
    g_bytes_sent += bytes.size();
    Transfer& t = g_sends.emplace_back();
    t.tag = tag;
    t.message.bytes = std::move(bytes);
    check(MPI_Isend(t.message.bytes.data(), int(t.message.bytes.size()), MPI_BYTE, dest, tag,
                    MPI_COMM_WORLD, &t.request),
          "MPI_Isend");
}

bool progress() {
    while (!g_sends.empty()) {
        int done = 0;
        check(MPI_Test(&g_sends.front().request, &done, MPI_STATUS_IGNORE), "MPI_Test");
        if (!done) break;
        g_sends.pop_front();
    }
    return g_sends.empty();
}

std::optional<Message> try_receive(int tag, int source) {
    progress();
    // Start receiving every message that has begun to arrive (matched probes, so each is
    // received by the receive started for it)
    for (;;) {
        int flag = 0;
        MPI_Message handle;
        MPI_Status status;
        check(MPI_Improbe(source < 0 ? MPI_ANY_SOURCE : source, tag < 0 ? MPI_ANY_TAG : tag,
                          MPI_COMM_WORLD, &flag, &handle, &status),
              "MPI_Improbe");
        if (!flag) break;
        int count = 0;
        MPI_Get_count(&status, MPI_BYTE, &count);
        tally(g_received, status.MPI_SOURCE);
        Transfer& t = g_receives.emplace_back();
        t.tag = status.MPI_TAG;
        t.message.source = status.MPI_SOURCE;
        t.message.tag = status.MPI_TAG;
        if (!g_buffers.empty()) {
            t.message.bytes = std::move(g_buffers.back());
            g_buffers.pop_back();
        }
        t.message.bytes.resize(size_t(count));
        check(MPI_Imrecv(t.message.bytes.data(), count, MPI_BYTE, &handle, &t.request),
              "MPI_Imrecv");
    }
    // The first complete one of this tag and source (earlier ones of a sender first)
    for (auto it = g_receives.begin(); it != g_receives.end(); ++it) {
        if ((tag >= 0 && it->tag != tag) || (source >= 0 && it->message.source != source)) continue;
        int done = 0;
        check(MPI_Test(&it->request, &done, MPI_STATUS_IGNORE), "MPI_Test");
        if (!done) {
            // (a later message of the same sender must not overtake this one)
            if (source >= 0) break;
            continue;
        }
        bool earlier_pending = false;
        for (auto e = g_receives.begin(); e != it; ++e)
            earlier_pending |=
                (tag < 0 || e->tag == tag) && e->message.source == it->message.source;
        if (earlier_pending) continue;
        Message m = std::move(it->message);
        g_receives.erase(it);
        return m;
    }
    return std::nullopt;
}

void recycle(std::vector<char>&& bytes) {
    if (g_buffers.size() < 16) g_buffers.push_back(std::move(bytes));
}

uint64_t bytes_sent() { return g_bytes_sent; }

void drain() {
    if (!g_started) return;
    g_sent.resize(size_t(g_world.size)), g_received.resize(size_t(g_world.size));
    std::vector<uint64_t> coming(size_t(g_world.size));
    check(MPI_Alltoall(g_sent.data(), 1, MPI_UINT64_T, coming.data(), 1, MPI_UINT64_T,
                       MPI_COMM_WORLD),
          "MPI_Alltoall");
    // The receives started and not taken, then every message not yet started
    for (Transfer& t : g_receives) check(MPI_Wait(&t.request, MPI_STATUS_IGNORE), "MPI_Wait");
    g_receives.clear();
    std::vector<char> scratch;
    for (int r = 0; r < g_world.size; ++r)
        while (g_received[size_t(r)] < coming[size_t(r)]) {
            MPI_Message handle;
            MPI_Status status;
            check(MPI_Mprobe(r, MPI_ANY_TAG, MPI_COMM_WORLD, &handle, &status), "MPI_Mprobe");
            int n = 0;
            MPI_Get_count(&status, MPI_BYTE, &n);
            scratch.resize(size_t(std::max(n, 1)));
            check(MPI_Mrecv(scratch.data(), n, MPI_BYTE, &handle, MPI_STATUS_IGNORE), "MPI_Mrecv");
            ++g_received[size_t(r)];
        }
    while (!progress()) {
    }
    std::fill(g_sent.begin(), g_sent.end(), 0);
    std::fill(g_received.begin(), g_received.end(), 0);
}

std::vector<std::vector<char>> gather(const void* data, size_t bytes) {
    std::vector<char> all(g_world.rank == 0 ? bytes * size_t(g_world.size) : 0);
    check(
        MPI_Gather(data, int(bytes), MPI_BYTE, all.data(), int(bytes), MPI_BYTE, 0, MPI_COMM_WORLD),
        "MPI_Gather");
    std::vector<std::vector<char>> out;
    for (int r = 0; g_world.rank == 0 && r < g_world.size; ++r)
        out.emplace_back(all.begin() + ptrdiff_t(bytes) * r,
                         all.begin() + ptrdiff_t(bytes) * (r + 1));
    return out;
}

}  // namespace cierzo::mpi
