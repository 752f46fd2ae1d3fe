// A file mapped read-only, or read whole where the file system refuses a mapping
// (mapped_file.h).
#include "io/mapped_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <limits>
#include <system_error>

#include <fmt/format.h>

#include "core/error.h"
#include "io/input_file.h"

namespace cierzo {

namespace {

// An open file, closed however the constructor leaves (a mapping outlives its descriptor).
struct Descriptor {
    int fd = -1;
    ~Descriptor() {
        if (fd >= 0) ::close(fd);
    }
};

std::string error_text(int error) {
    return std::error_code(error, std::generic_category()).message();
}

}  // namespace

MappedFile::MappedFile(const std::filesystem::path& path) {
    const std::string name = path.string();
    const auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
    if (!input_file_exists(path)) fail("file does not exist");
    const Descriptor file{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
    if (file.fd < 0) fail("cannot open file for reading: " + error_text(errno));
    struct stat status = {};
    if (::fstat(file.fd, &status) != 0) fail("cannot read its size: " + error_text(errno));
    // (input_file_exists looked at the path; what was opened may have replaced it since)
    if (!S_ISREG(status.st_mode)) fail("is not a regular file");
    if (status.st_size <= 0) return;
    const uint64_t size = uint64_t(status.st_size);
    if (size > std::numeric_limits<size_t>::max())
        fail(fmt::format("at {} bytes it is larger than this program can address", size));

    // Mapped: nothing is read until a reader looks at it
    void* map = ::mmap(nullptr, size_t(size), PROT_READ, MAP_PRIVATE, file.fd, 0);
    if (map != MAP_FAILED) {
        data_ = static_cast<const char*>(map);
        size_ = size_t(size);
        mapped_ = true;
        ::madvise(map, size_, MADV_SEQUENTIAL);  // (a hint: the readers go front to back)
        return;
    }

    // Read whole instead, up to its end (a sysfs file holds less than its size says)
    const int map_error = errno;
    if (size > reader_memory_bound())
        fail(fmt::format(
            "cannot map it into memory ({}), and at {} bytes it is larger than the {} bytes a "
            "file may take (half this machine's memory) to read whole",
            error_text(map_error), size, reader_memory_bound()));
    copy_.resize(size_t(size));
    size_t done = 0;
    while (done < copy_.size()) {
        const ssize_t n = ::read(file.fd, copy_.data() + done, copy_.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail("read error: " + error_text(errno));
        if (n == 0) break;
        done += size_t(n);
    }
    copy_.resize(done);
    data_ = copy_.data();
    size_ = done;
}

MappedFile::~MappedFile() {
    if (mapped_) ::munmap(const_cast<char*>(data_), size_);
}

uint64_t physical_memory_bytes() {
    const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page <= 0) return std::numeric_limits<uint64_t>::max();
    return uint64_t(pages) * uint64_t(page);
}

uint64_t reader_memory_bound() { return physical_memory_bytes() / 2; }

}  // namespace cierzo
