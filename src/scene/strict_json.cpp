// The scene file's JSON reader: nlohmann's SAX parser feeding a document builder of our own
// that checks keys and depth as each value arrives. (nlohmann's own parser with a callback
// did these checks too, but after each object it scans the whole enclosing array for
// discarded values: quadratic in an array's length, 6.5 s for 100,000 spheres, 22 s for
// 200,000, 485 s for a million.)
#include "scene/strict_json.h"

#include <utility>
#include <vector>

#include "core/error.h"

namespace cierzo {

namespace {

using nlohmann::json;

// Receives the parser's events in order and builds the document, the way nlohmann's own
// json_sax_dom_parser does, with the checks added.
class StrictDocumentBuilder {
public:
    StrictDocumentBuilder(const std::filesystem::path& file, const JsonStream* stream)
        : file_(file), stream_(stream) {}

    json document;

    bool null() { return put(nullptr); }
    bool boolean(bool v) { return put(v); }
    bool number_integer(json::number_integer_t v) { return put(v); }
    bool number_unsigned(json::number_unsigned_t v) { return put(v); }
    bool number_float(json::number_float_t v, const json::string_t& /*text*/) { return put(v); }
    bool string(json::string_t& v) { return put(v); }
    bool binary(json::binary_t& v) { return put(json::binary(v)); }

    bool start_object(std::size_t /*elements*/) { return open(json::value_t::object); }
    bool start_array(std::size_t /*elements*/) { return open(json::value_t::array); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }

    bool key(json::string_t& k) {
        Open& object = open_.back();
        auto [it, fresh] = object.value->get_ref<json::object_t&>().try_emplace(k);
        if (!fresh)
            throw InputError(file_.string() + ": " + name(open_.size() - 1) + ": duplicate key '" +
                             k + "' (each key may be given once)");
        object.key = &it->first;
        object.member = &it->second;
        return true;
    }

    // A syntax error (with line and column) or a number beyond a double: thrown as the
    // parser made it, to be reworded by parse_strict_json
    template <class Exception>
    bool parse_error(std::size_t /*position*/, const std::string& /*token*/, const Exception& e) {
        throw e;
    }

private:
    // An array or object being filled: for an array, how many elements it has had (a
    // streamed one keeps none) and whether it is streamed; for an object, its latest key and
    // that key's value
    struct Open {
        json* value;
        size_t count = 0;
        bool streamed = false;
        const std::string* key = nullptr;
        json* member = nullptr;
    };

    // A value goes into the innermost open array or object (or is the document)
    json* place(json&& v) {
        if (open_.empty()) {
            document = std::move(v);
            return &document;
        }
        Open& parent = open_.back();
        if (parent.value->is_array()) {
            json::array_t& a = parent.value->get_ref<json::array_t&>();
            a.push_back(std::move(v));
            ++parent.count;
            return &a.back();
        }
        *parent.member = std::move(v);
        return parent.member;
    }
    bool put(json&& v) {
        place(std::move(v));
        complete();
        return true;
    }
    // The latest value placed is complete: handed over if its array is streamed
    void complete() {
        if (open_.empty() || !open_.back().streamed) return;
        json::array_t& a = open_.back().value->get_ref<json::array_t&>();
        stream_->element(a.back(), open_.back().count - 1);
        a.pop_back();
    }

    bool open(json::value_t kind) {
        if (open_.size() >= size_t(kMaxJsonNesting))
            throw InputError(file_.string() + ": invalid JSON: arrays and objects nested " +
                             "deeper than " + std::to_string(kMaxJsonNesting) + " levels");
        // (its parent grows no more while it is open, so the pointer stays valid)
        json* value = place(json(kind));
        const bool streamed = stream_ && kind == json::value_t::array && open_.size() == 1 &&
                              open_[0].value->is_object() && *open_[0].key == stream_->key &&
                              stream_->begin(document);
        open_.push_back({value, 0, streamed});
        return true;
    }
    bool close() {
        open_.pop_back();
        complete();
        return true;
    }

    // Where the i-th open value is, for messages: "scene" (the document), "render",
    // "objects[2]", "materials.white.kd" (built only for a message)
    std::string name(size_t i) const {
        if (i == 0) return "scene";
        const Open& parent = open_[i - 1];
        if (parent.value->is_array())
            return name(i - 1) + "[" + std::to_string(parent.count - 1) + "]";
        return i == 1 ? *parent.key : name(i - 1) + "." + *parent.key;
    }

    const std::filesystem::path& file_;
    const JsonStream* stream_;
    std::vector<Open> open_;
};

}  // namespace

json parse_strict_json(const std::string& text, const std::filesystem::path& file,
                       const JsonStream* stream) {
    StrictDocumentBuilder builder(file, stream);
    try {
        json::sax_parse(text, &builder, json::input_format_t::json, /*strict=*/true,
                        /*ignore_comments=*/true);
    } catch (const json::exception& e) {
        // parse_error (with line and column), or out_of_range for a number such as 1e400
        // that overflows a double
        std::string what = e.what();
        const auto bracket = what.find("] ");
        if (what.rfind("[json.exception.", 0) == 0 && bracket != std::string::npos)
            what = what.substr(bracket + 2);
        throw InputError(file.string() + ": invalid JSON: " + what);
    }
    return std::move(builder.document);
}

}  // namespace cierzo
