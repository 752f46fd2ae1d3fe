// Several processes under MPI: the little of MPI that the render driver uses, behind an
// interface that needs no MPI header. A build without MPI (CIERZO_MPI=OFF, or no MPI found)
// links distributed_none.cpp, where the world is one process and nothing is ever sent.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cierzo::mpi {

struct World {
    int rank = 0;
    int size = 1;
};

// Whether this build can run under MPI.
bool built_with_mpi();

// Starts MPI if this process was launched by an MPI launcher (mpirun, mpiexec, or Slurm's
// srun: it sees OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_SIZE); otherwise, or in a build
// without MPI, does nothing and the world is this one process. Call once, first in main.
void init(int* argc, char*** argv);
// Ends MPI after a normal run (every rank calls it).
void finalize();
// Ends every rank of the run at once with `code` (after an error on any one of them).
[[noreturn]] void abort(int code);

const World& world();
std::string host_name();

struct Message {
    int source = 0;
    std::vector<char> bytes;
    int tag = 0;
};

// Point-to-point messages of bytes with a tag, none of which blocks: a blocked MPI call
// spins its core in most MPI libraries, and a large message waits for the receiver.
// `send` starts sending (the bytes are kept until sent); `progress` moves pending sends on
// and returns whether none is left; call it in every turn of a polling loop.
void send(int dest, int tag, std::vector<char> bytes);
bool progress();
// A message with this tag (-1: any tag), from `source` (-1: any rank), once it has fully
// arrived (the receive is started by an earlier call when needed); messages of one sender
// (and tag) come in the order they were sent.
std::optional<Message> try_receive(int tag, int source = -1);
// Hands a received message's buffer back for later receives (large buffers would otherwise
// be fresh pages, faulted in one by one, for every message).
void recycle(std::vector<char>&& bytes);
// Receives and drops every message still on its way to this rank (a collective call, once
// no rank sends any more: every rank learns how many messages each other sent it), and
// finishes this rank's sends; so no rank waits at the end on a message nobody reads.
void drain();
// Bytes this rank has sent to other ranks.
uint64_t bytes_sent();
// Rank 0 receives every rank's `bytes` (the same size on every rank), in rank order;
// the other ranks receive nothing.
std::vector<std::vector<char>> gather(const void* data, size_t bytes);

}  // namespace cierzo::mpi
