// Atomic file replacement: writers fill a temporary file next to the destination, which is
// renamed over it only once complete, so a reader never sees a half-written file and a
// failed write leaves any existing file untouched.
#pragma once

#include <filesystem>
#include <fstream>
#include <functional>

namespace cierzo {

// Creates a uniquely named, empty temporary file in the directory of `path`
// (".<name>.tmp.<pid>.<counter>"), calls `write(tmp)` to fill it, flushes it to disk and
// renames it to `path`. If anything fails (the destination folder is missing or not
// writable, `path` is a directory, `write` throws, the rename fails) the temporary file is
// removed, an existing file at `path` is left as it was, and an InputError is thrown whose
// message starts with "<path>: cannot write: " followed by the reason. An InputError thrown
// by `write` itself is passed on unchanged; other std::exceptions are wrapped.
void write_atomically(const std::filesystem::path& path,
                      const std::function<void(const std::filesystem::path& tmp)>& write);

// The same for writers that produce a byte stream: `write` fills a binary std::ofstream
// opened on the temporary file, whose state is checked after `write` returns and again
// after flush and close (so a full disk is reported, not silently ignored).
void write_stream_atomically(const std::filesystem::path& path,
                             const std::function<void(std::ofstream& out)>& write);

}  // namespace cierzo
