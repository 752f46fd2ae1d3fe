// The world of a build without MPI: this one process.
#include "integrators/distributed.h"

#include <cstdlib>
#include <stdexcept>

#include <unistd.h>

namespace cierzo::mpi {

bool built_with_mpi() { return false; }
void init(int*, char***) {}
void finalize() {}
void abort(int code) { std::exit(code); }

const World& world() {
    static const World w;
    return w;
}

std::string host_name() {
    char name[256] = {};
    if (gethostname(name, sizeof(name) - 1) != 0) return "unknown";
    return name;
}

void send(int, int, std::vector<char>) {
    throw std::logic_error("mpi::send in a build without MPI");
}
bool progress() { return true; }
void recycle(std::vector<char>&&) {}
void drain() {}
uint64_t bytes_sent() { return 0; }
std::optional<Message> try_receive(int, int) { return std::nullopt; }
std::vector<std::vector<char>> gather(const void* data, size_t bytes) {
    const char* p = static_cast<const char*>(data);
    return {std::vector<char>(p, p + bytes)};
}

}  // namespace cierzo::mpi
