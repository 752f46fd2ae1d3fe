// Errors that reach the user: bad input files, bad options, unwritable outputs.
// Every message names the file (or option) and says what is wrong with it.
#pragma once

#include <stdexcept>
#include <string>

namespace cierzo {

// Thrown for anything the user can fix: a malformed scene or PLY, a bad option, an
// unwritable path. Programs catch it in main, print what(), and exit non-zero.
class InputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace cierzo
