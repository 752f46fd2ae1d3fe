// The output-file policy (see output_file.h): links followed and written through, streams
// written directly, regular files replaced atomically, clashes with inputs refused.
#include "io/output_file.h"

#include "core/error.h"

#include <atomic>
#include <cerrno>
#include <charconv>
#include <exception>
#include <optional>
#include <system_error>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

namespace cierzo {

namespace fs = std::filesystem;

namespace {

std::atomic<unsigned long> temp_counter{0};

// Longest file-name prefix copied into a temporary name, so that it stays under NAME_MAX.
constexpr size_t kMaxTempStem = 200;
// Links followed before a path is taken for a loop (as the kernel's ELOOP limit).
constexpr int kMaxLinks = 40;

std::string errno_text(int err) { return std::generic_category().message(err); }

// "<path>: cannot write[ <what>]: "
std::string cannot(const fs::path& path, const std::string& what) {
    return path.string() + ": cannot write" + (what.empty() ? "" : " " + what) + ": ";
}

[[noreturn]] void fail(const fs::path& path, const std::string& reason) {
    throw InputError(cannot(path, "") + reason);
}

// N for /proc/self/fd/N, /proc/<this process>/fd/N or /dev/fd/N: paths that name one of the
// process's open descriptors (what /dev/stdout links to); otherwise nothing.
std::optional<int> descriptor_of(const fs::path& path) {
    const std::string p = path.lexically_normal().string();
    std::string own = "/proc/";  // (appended: GCC 12 warns falsely of "a" + string + "b")
    own += std::to_string(::getpid());
    own += "/fd/";
    for (const std::string& prefix :
         {std::string("/proc/self/fd/"), std::string("/dev/fd/"), own}) {
        if (p.size() <= prefix.size() || p.compare(0, prefix.size(), prefix) != 0) continue;
        int fd = -1;
        const char* end = p.data() + p.size();
        const auto [ptr, ec] = std::from_chars(p.data() + prefix.size(), end, fd);
        if (ec == std::errc() && ptr == end && fd >= 0) return fd;
    }
    return std::nullopt;
}

// Where `path` leads once its symbolic links are followed: the last path of the chain (which
// is not a link, or does not exist), or an open descriptor.
struct LinkEnd {
    fs::path path;
    std::optional<int> descriptor;
};

LinkEnd follow_links(const fs::path& path, const std::string& what) {
    if (path == "-") return {path, STDOUT_FILENO};
    fs::path p = path;
    for (int links = 0;; ++links) {
        if (const std::optional<int> fd = descriptor_of(p)) return {p, fd};
        struct stat st;
        if (::lstat(p.c_str(), &st) != 0) {
            if (errno == ENOENT) return {p, std::nullopt};
            throw InputError(cannot(path, what) + errno_text(errno));
        }
        if (!S_ISLNK(st.st_mode)) return {p, std::nullopt};
        if (links == kMaxLinks)
            throw InputError(cannot(path, what) + "too many levels of symbolic links");
        std::error_code ec;
        const fs::path target = fs::read_symlink(p, ec);
        if (ec) throw InputError(cannot(path, what) + ec.message());
        p = target.is_absolute() ? target : p.parent_path() / target;
    }
}

// What a path is, for comparing outputs with inputs and with each other.
struct Identity {
    bool exists = false;
    dev_t device = 0;
    ino_t inode = 0;
    bool null_device = false;  // may stand for several outputs
    std::string where;         // a file not there yet: its path, links and folders resolved
};

Identity identity_of_stat(const struct stat& st) {
    Identity id;
    id.exists = true;
    id.device = st.st_dev;
    id.inode = st.st_ino;
    id.null_device = S_ISCHR(st.st_mode) && major(st.st_rdev) == 1 && minor(st.st_rdev) == 3;
    return id;
}

// The identity of an existing file (links followed), or nothing.
std::optional<Identity> existing_identity(const fs::path& path) {
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) return std::nullopt;
    return identity_of_stat(st);
}

// The identity of what a resolved output writes to.
Identity output_identity(const OutputTarget& target) {
    struct stat st;
    if (target.descriptor >= 0 && ::fstat(target.descriptor, &st) == 0) return identity_of_stat(st);
    if (std::optional<Identity> id = existing_identity(target.file)) return *id;
    Identity id;
    std::error_code ec;
    fs::path resolved = fs::absolute(target.file, ec);
    if (!ec) resolved = fs::weakly_canonical(resolved, ec);
    id.where = (ec ? target.file.lexically_normal() : resolved).string();
    return id;
}

bool same_file(const Identity& a, const Identity& b) {
    if (a.exists != b.exists) return false;
    if (!a.exists) return a.where == b.where;
    return a.device == b.device && a.inode == b.inode && !(a.null_device && b.null_device);
}

// Creates an empty file with a new unique name in `dir` and returns its path.
fs::path create_temp_file(const fs::path& path, const fs::path& dir, const std::string& stem) {
    for (int attempt = 0; attempt < 100; ++attempt) {
        std::string name = ".";  // (appended: GCC 12 warns falsely of "a" + string)
        name += stem.substr(0, kMaxTempStem);
        name +=
            ".tmp." + std::to_string(::getpid()) + "." + std::to_string(temp_counter.fetch_add(1));
        const fs::path tmp = dir / name;
        const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            return tmp;
        }
        if (errno != EEXIST) fail(path, errno_text(errno));
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
    if (fd < 0) fail(path, "temporary file " + tmp.string() + " vanished: " + errno_text(errno));
    const int result = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    if (result != 0) fail(path, errno_text(err));
}

// Runs `write(tmp)`, removing `tmp` on any failure; the writer's InputError passes unchanged.
void fill_temp(const fs::path& path, const fs::path& tmp,
               const std::function<void(const fs::path& tmp)>& write) {
    try {
        write(tmp);
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
}

// A regular file (or a new one): a temporary beside it, synced, renamed over it.
void replace_file(const fs::path& path, const fs::path& file,
                  const std::function<void(const fs::path& tmp)>& write) {
    const fs::path dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
    const fs::path tmp = create_temp_file(path, dir, file.filename().string());
    fill_temp(path, tmp, write);
    try {
        sync_file(path, tmp);
        // The replaced file keeps its permission bits
        struct stat old;
        if (::stat(file.c_str(), &old) == 0 && ::chmod(tmp.c_str(), old.st_mode & 07777) != 0)
            fail(path, errno_text(errno));
    } catch (...) {
        remove_quietly(tmp);
        throw;
    }
    if (::rename(tmp.c_str(), file.c_str()) != 0) {
        const int err = errno;
        remove_quietly(tmp);
        fail(path, errno_text(err));
    }
}

// A stream: the writer fills a temporary file in the system's temporary folder, which is then
// copied to the stream.
void write_stream_target(const fs::path& path, const OutputTarget& target,
                         const std::function<void(const fs::path& tmp)>& write) {
    std::error_code ec;
    fs::path dir = fs::temp_directory_path(ec);
    if (ec) dir = "/tmp";
    const fs::path tmp = create_temp_file(path, dir, "cierzo-output");
    fill_temp(path, tmp, write);
    try {
        std::ifstream in(tmp, std::ios::binary);
        if (!in) fail(path, "cannot read back temporary file " + tmp.string());
        StreamOutput out(path, target);
        std::vector<char> buffer(size_t(1) << 20);
        while (in) {
            in.read(buffer.data(), std::streamsize(buffer.size()));
            if (in.gcount() > 0) out.write({buffer.data(), size_t(in.gcount())});
        }
        if (in.bad()) fail(path, "cannot read back temporary file " + tmp.string());
        out.close();
    } catch (...) {
        remove_quietly(tmp);
        throw;
    }
    remove_quietly(tmp);
}

}  // namespace

OutputTarget resolve_output(const fs::path& path, const std::string& what) {
    if (path.empty())
        throw InputError("cannot write" + (what.empty() ? "" : " " + what) + ": empty file name");
    const LinkEnd end = follow_links(path, what);
    OutputTarget t;
    if (end.descriptor) {
        if (::fcntl(*end.descriptor, F_GETFD) == -1)
            throw InputError(cannot(path, what) + "descriptor " + std::to_string(*end.descriptor) +
                             " is not open");
        t.kind = OutputTarget::Kind::kStream;
        t.descriptor = *end.descriptor;
        return t;
    }
    const fs::path& p = end.path;
    struct stat st;
    if (::stat(p.c_str(), &st) == 0) {
        if (S_ISDIR(st.st_mode)) throw InputError(cannot(path, what) + "it is a folder");
        if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) {
            if (::access(p.c_str(), W_OK) != 0)
                throw InputError(cannot(path, what) + errno_text(errno));
            t.kind = OutputTarget::Kind::kStream;
            t.file = p;
            return t;
        }
        if (!S_ISREG(st.st_mode))
            throw InputError(cannot(path, what) + "it is a " +
                             (S_ISBLK(st.st_mode) ? "block device" : "socket") +
                             "; outputs are files, character devices, FIFOs or standard output");
    } else if (errno != ENOENT) {
        throw InputError(cannot(path, what) + errno_text(errno));
    }
    if (!p.has_filename()) throw InputError(cannot(path, what) + "not a file name");
    // A new or replaced file: its folder must exist and take new files
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw InputError(cannot(path, what) + "folder '" + dir.string() + "' does not exist");
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
        throw InputError(cannot(path, what) + "folder '" + dir.string() +
                         "': " + errno_text(errno));
    t.kind = OutputTarget::Kind::kFile;
    t.file = p;
    return t;
}

void check_outputs(const std::vector<OutputPath>& outputs, const std::vector<InputPath>& inputs) {
    std::vector<std::pair<const InputPath*, Identity>> existing;
    for (const InputPath& in : inputs) {
        const std::optional<Identity> id =
            in.path.empty() ? std::nullopt : existing_identity(in.path);
        if (id) existing.emplace_back(&in, *id);
    }
    std::vector<std::pair<const OutputPath*, Identity>> seen;
    for (const OutputPath& out : outputs) {
        if (out.path.empty()) continue;
        const Identity id = output_identity(resolve_output(out.path, out.what));
        for (const auto& [in, in_id] : existing)
            if (same_file(id, in_id))
                throw InputError(out.path.string() + ": " + out.option + " is the same file as " +
                                 in->what + " " + in->path.string() + "; nothing was written");
        for (const auto& [other, other_id] : seen)
            if (same_file(id, other_id))
                throw InputError(out.path.string() + ": " + out.option + " is the same file as " +
                                 other->option + " " + other->path.string() +
                                 "; nothing was written");
        seen.emplace_back(&out, id);
    }
}

bool writes_over(const fs::path& output, const fs::path& input) {
    const std::optional<Identity> in = existing_identity(input);
    return in && same_file(output_identity(resolve_output(output)), *in);
}

void write_output(const fs::path& path, const std::function<void(const fs::path& tmp)>& write) {
    const OutputTarget target = resolve_output(path);
    if (target.kind == OutputTarget::Kind::kStream)
        write_stream_target(path, target, write);
    else
        replace_file(path, target.file, write);
}

void write_output_stream(const fs::path& path,
                         const std::function<void(std::ofstream& out)>& write) {
    write_output(path, [&](const fs::path& tmp) {
        errno = 0;
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out)
            fail(path, "cannot open temporary file " + tmp.string() + ": " + errno_text(errno));
        const auto check = [&](const char* what) {
            if (!out) fail(path, errno != 0 ? std::string(what) + ": " + errno_text(errno) : what);
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

StreamOutput::StreamOutput(const fs::path& path, const OutputTarget& target) : path_(path) {
    if (target.descriptor >= 0) {
        fd_ = target.descriptor;
        return;
    }
    do {
        fd_ = ::open(target.file.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
    } while (fd_ < 0 && errno == EINTR);
    if (fd_ < 0) fail(path_, errno_text(errno));
    owned_ = true;
}

StreamOutput::~StreamOutput() {
    if (owned_ && fd_ >= 0) ::close(fd_);
}

void StreamOutput::write(std::string_view bytes) {
    while (!bytes.empty()) {
        const ssize_t n = ::write(fd_, bytes.data(), bytes.size());
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail(path_, errno_text(errno));
        if (n == 0) fail(path_, "short write");
        bytes.remove_prefix(size_t(n));
    }
}

void StreamOutput::close() {
    if (!owned_ || fd_ < 0) return;
    const int result = ::close(fd_);
    fd_ = -1;
    if (result != 0 && errno != EINTR) fail(path_, "error closing the file: " + errno_text(errno));
}

}  // namespace cierzo
