// Several processes under MPI: the little of MPI that the render driver uses, behind an
// interface that needs no MPI header. A build without MPI (CIERZO_MPI=OFF, or no MPI found)
// links distributed_none.cpp, where the world is one process and nothing is ever sent.
#pragma once

#include <cstddef>
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
};

// Point-to-point messages of bytes with a tag. `send` returns once the buffer may be reused.
void send(int dest, int tag, const void* data, size_t bytes);
// A message with this tag, from `source` (-1: any rank), if one has arrived; never blocks.
std::optional<Message> try_receive(int tag, int source = -1);
// Rank 0 receives every rank's `bytes` (the same size on every rank), in rank order;
// the other ranks receive nothing.
std::vector<std::vector<char>> gather(const void* data, size_t bytes);

}  // namespace cierzo::mpi
