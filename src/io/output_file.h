// Output files: the one policy every writer follows (images, --stats, checkpoints, the CSV of
// `converge` and its reference, the tone mapper's images, the Python module's writers).
//
// - No output may be the same file as an input or as another output. check_outputs compares
//   them by identity (device and inode, links followed; the resolved path where a file does
//   not exist yet) and refuses a clash before any work starts, naming both.
// - A regular file is replaced atomically: a temporary file beside it is written, synced and
//   renamed over it (keeping its permission bits), so a failed write leaves the old file
//   byte for byte and never a partial file under the final name.
// - A symbolic link is written through: the temporary file goes beside the link's final
//   target, which is replaced; the link survives and points at the new data.
// - Standard output ("-", and /dev/stdout or /proc/self/fd/N through their links), character
//   devices (/dev/null) and FIFOs are written directly: no temporary file beside them, no
//   rename. Block devices, sockets and folders are refused.
// - Every failure (a missing folder, a full disk, a closed pipe, a short write, an error at
//   close or rename) throws InputError naming the path as it was given.
#pragma once

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace cierzo {

// The policy in three lines, for --help.
inline constexpr const char* kOutputPolicy =
    "Outputs: one that is the same file as an input or another output is refused before any "
    "work;\nan existing file is replaced only once the new one is complete, a symbolic link is "
    "written through\nto its target, and standard output (-), devices and FIFOs are written "
    "directly.";

// Where writing to a path leads, its links followed.
struct OutputTarget {
    enum class Kind {
        kFile,    // a regular file (existing or not) replaced atomically
        kStream,  // standard output, a character device or a FIFO, written directly
    };
    Kind kind = Kind::kFile;
    // kFile: the file replaced or created (a link's final target); kStream: the device or
    // FIFO to open, empty when `descriptor` is already open
    std::filesystem::path file;
    int descriptor = -1;  // kStream: 1 for "-" and /dev/stdout, N for /proc/self/fd/N
};

// Resolves `path` for writing. Throws InputError "<path>: cannot write <what>: <why>" (with
// no "<what>" when it is empty) for a missing folder, a folder, a block device, a socket, a
// closed descriptor or a loop of links.
OutputTarget resolve_output(const std::filesystem::path& path, const std::string& what = "");

// An output of a command: its path, the option that names it in messages ("--stats") and
// what it holds ("the statistics"). An empty path is no output.
struct OutputPath {
    std::filesystem::path path;
    std::string option;
    std::string what;
};

// An input of a command: its path and what it is ("the scene file"). An input that does not
// exist (a scene given as a Python dict) is passed over.
struct InputPath {
    std::filesystem::path path;
    std::string what;
};

// Checks, before any work starts, that every output can be written (resolve_output) and that
// none is the same file as an input or another output: InputError "<path>: --stats is the
// same file as the scene file scene.json". The null device may stand for several outputs.
void check_outputs(const std::vector<OutputPath>& outputs, const std::vector<InputPath>& inputs);

// Whether writing to `output` would replace the existing file `input` (false when either is
// missing).
bool writes_over(const std::filesystem::path& output, const std::filesystem::path& input);

// Writes an output by the policy above: `write(tmp)` fills a new, empty temporary file (beside
// the final file, or in the system's temporary folder for a stream, which is then copied to
// it). An InputError thrown by `write` passes unchanged; other std::exceptions are wrapped as
// "<path>: cannot write: <what>". The temporary file is always removed.
void write_output(const std::filesystem::path& path,
                  const std::function<void(const std::filesystem::path& tmp)>& write);

// The same for writers that produce a byte stream: `write` fills a binary std::ofstream on the
// temporary file, whose state is checked after `write` returns and after flush and close (so
// a full disk is reported, not ignored).
void write_output_stream(const std::filesystem::path& path,
                         const std::function<void(std::ofstream& out)>& write);

// An output written piece by piece as it is produced, for a stream target (the CSV rows of
// `converge` on standard output or a FIFO). Opening a FIFO waits for its reader, as a shell
// redirection does. Errors throw InputError naming the path.
class StreamOutput {
public:
    StreamOutput(const std::filesystem::path& path, const OutputTarget& target);
    ~StreamOutput();
    StreamOutput(const StreamOutput&) = delete;
    StreamOutput& operator=(const StreamOutput&) = delete;

    void write(std::string_view bytes);
    // Closes a descriptor it opened (standard output stays open); reports an error at close.
    void close();

private:
    std::filesystem::path path_;
    int fd_ = -1;
    bool owned_ = false;
};

}  // namespace cierzo
