// JSON text to a document (nlohmann::json) in one pass, in time linear in the text, refusing
// while it reads what a scene file must not hold: a key given twice in one object, and
// arrays and objects nested too deep.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace cierzo {

// Far deeper than any scene needs (5 levels); deeper input would overflow the stack of the
// recursive copies and dumps the scene reader makes of values.
constexpr int kMaxJsonNesting = 64;

// The elements of one array of the document's top object, handed over one by one as each is
// read instead of being kept (the document then holds that array empty): a file of a million
// objects is never a document of a million objects.
struct JsonStream {
    std::string key;  // the top object's key whose array may be streamed
    // Called as that array opens, with the document read so far: whether to stream it
    std::function<bool(const nlohmann::json& document)> begin;
    // Called with each element, complete, and its index in the array
    std::function<void(const nlohmann::json& element, size_t index)> element;
};

// Parses `text` (standard JSON; `//` and `/* */` comments allowed). Throws InputError naming
// `file`: "FILE: objects[2]: duplicate key 'radius' (each key may be given once)", "FILE:
// invalid JSON: arrays and objects nested deeper than 64 levels", and for malformed text or a
// number that overflows a double, "FILE: invalid JSON: " and the reader's message (which says
// the line and column).
nlohmann::json parse_strict_json(const std::string& text, const std::filesystem::path& file,
                                 const JsonStream* stream = nullptr);

}  // namespace cierzo
