// A file's bytes as a read-only memory mapping (POSIX mmap, MAP_PRIVATE): a reader looks at
// the part it needs (a PLY header, then the body the header declares) and the rest of the
// file is never read. Used by the mesh readers (PLY, OBJ, MTL: mesh_file.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace cierzo {

// The file is mapped whole, read-only; an empty file is an empty view (nothing mapped).
// Where the file system refuses a mapping (sysfs, some FUSE file systems), the file is read
// into memory instead, if it is no larger than reader_memory_bound(). Throws InputError
// naming the file when it is missing or not a regular file (input_file_exists), cannot be
// opened, or can be neither mapped nor read. A file cut short by another program while it
// is mapped ends this one with SIGBUS where the reader touches the missing part, as any
// mapping of it would.
class MappedFile {
public:
    explicit MappedFile(const std::filesystem::path& path);
    ~MappedFile();
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;

    std::string_view bytes() const { return {data_, size_}; }
    // Whether the bytes are a mapping (false: empty, or read because mapping was refused)
    bool mapped() const { return mapped_; }

private:
    const char* data_ = nullptr;
    size_t size_ = 0;
    bool mapped_ = false;
    std::string copy_;  // the bytes when read instead of mapped
};

// This machine's physical memory in bytes (sysconf: _SC_PHYS_PAGES × _SC_PAGE_SIZE), or 2^64 − 1
// when it cannot be told.
uint64_t physical_memory_bytes();

// What the reader of one file may allocate for it: half of physical_memory_bytes(), the rest
// left to what is built from it (a mesh's BVH) and to the rest of the scene. A file whose
// claims need more is refused before anything is allocated for them.
uint64_t reader_memory_bound();

}  // namespace cierzo
