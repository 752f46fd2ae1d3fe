// The check of an input file before it is opened (see input_file.h).
#include "io/input_file.h"

#include <string>
#include <system_error>

#include "core/error.h"

namespace cierzo {

namespace fs = std::filesystem;

bool input_file_exists(const fs::path& path) {
    std::error_code ec;
    const fs::file_type type = fs::status(path, ec).type();  // (links followed)
    if (type == fs::file_type::regular) return true;
    if (type == fs::file_type::not_found) return false;
    const char* kind = nullptr;
    switch (type) {
        case fs::file_type::directory: kind = "a directory"; break;
        case fs::file_type::fifo: kind = "a FIFO (named pipe)"; break;
        case fs::file_type::character: kind = "a character device"; break;
        case fs::file_type::block: kind = "a block device"; break;
        case fs::file_type::socket: kind = "a socket"; break;
        default: break;
    }
    const std::string name = path.string();
    if (kind) throw InputError(name + ": is " + kind + ", not a regular file");
    if (ec) throw InputError(name + ": cannot read: " + ec.message());
    throw InputError(name + ": is not a regular file");
}

}  // namespace cierzo
