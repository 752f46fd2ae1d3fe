// cierzo-tonemap: reads an HDR image (.exr or .pfm), applies a tone-mapping operator and
// writes an 8-bit image (.png, .ppm or .bmp). The work is done by cierzo_tonemap/cierzo_io.
#include "core/error.h"
#include "io/image.h"
#include "io/output_file.h"
#include "tonemap/tonemap.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <csignal>
#include <cstdio>
#include <exception>
#include <string>

namespace {

std::string operator_footer() {
    std::string text =
        "Operators (x = max(input, 0) * 2^E per colour component; NaN/Inf count as 0;\n"
        "M = largest x in the image; V = --clamp; G = --gamma):\n";
    for (const cierzo::TonemapOperatorInfo& info : cierzo::tonemap_operators()) {
        text += fmt::format("  {:<16}{}\n", info.name, info.formula);
    }
    text +=
        "The result in [0, 1] is the final display value: it is quantised as round(v * 255)\n"
        "without any further sRGB encoding.\n";
    return text;
}

}  // namespace

int main(int argc, char** argv) {
    // A write into a closed pipe fails with EPIPE and is reported naming the file
    std::signal(SIGPIPE, SIG_IGN);
    CLI::App app{"Tone-map an HDR image (.exr, .pfm) into an 8-bit image (.png, .ppm, .bmp)."};
    std::string input;
    std::string output;
    cierzo::TonemapOptions options;
    float clamp = 1.0f;
    app.add_option("input", input, "HDR input image (.exr or .pfm)")->required();
    app.add_option("output", output, "LDR output image (.png, .ppm or .bmp)")->required();
    app.add_option("--op", options.op, "Tone-mapping operator (formulas below)")
        ->check(CLI::IsMember(cierzo::tonemap_operator_names()))
        ->capture_default_str();
    app.add_option("--exposure", options.exposure,
                   "Exposure E in stops: the input is multiplied by 2^E first, -64..64")
        ->capture_default_str();
    app.add_option("--gamma", options.gamma, "Gamma G of the gamma and clamp-gamma operators")
        ->capture_default_str();
    CLI::Option* clamp_option =
        app.add_option("--clamp", clamp,
                       "Saturation value V of clamp, equalize-clamp and clamp-gamma [default: 1]");
    app.footer(operator_footer() + "\n" + cierzo::kOutputPolicy + "\n");
    CLI11_PARSE(app, argc, argv);

    try {
        cierzo::check_outputs({{output, "the output image", "the image"}},
                              {{input, "the input image"}});
        if (*clamp_option) {
            options.clamp = clamp;
        }
        const cierzo::Image hdr = cierzo::read_hdr(input);
        cierzo::TonemapStats stats;
        const cierzo::Image ldr = cierzo::tonemap(hdr, options, &stats);
        if (stats.non_finite > 0) {
            fmt::print(stderr, "cierzo-tonemap: warning: {}: {} non-finite values treated as 0\n",
                       input, stats.non_finite);
        }
        cierzo::write_ldr(output, ldr);
    } catch (const std::exception& e) {
        fmt::print(stderr, "cierzo-tonemap: {}\n", e.what());
        return 1;
    }
    return 0;
}
