// The Python module `cierzo` (pybind11): scenes from files or dicts, renders and sweeps
// through the same code as `cierzo render` and `cierzo converge` (apps/render_job.h,
// apps/converge_command.h), images as float32 NumPy arrays, EXR files and tone mapping.
// (Over 600 lines as one file: a third of it is the functions' docstrings, which pybind11
// wants at the module's definition, beside the thin wrappers they document.)
#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cstring>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "apps/app_common.h"
#include "apps/converge_command.h"
#include "apps/render_job.h"
#include "core/error.h"
#include "integrators/wavefront/isa.h"
#include "io/image.h"
#include "integrators/registry.h"
#include "scene/scene_json.h"
#include "tonemap/tonemap.h"

namespace py = pybind11;
namespace fs = std::filesystem;
using namespace cierzo;

namespace {

// A scene as read, shared by every render of it (each render copies it to apply overrides).
struct PyScene {
    std::shared_ptr<const Scene> scene;
};

// A flag another Python thread (or a signal handler) sets to stop a render between passes.
struct Cancel {
    std::shared_ptr<std::atomic<bool>> flag = std::make_shared<std::atomic<bool>>(false);
};

PyObject* g_error = nullptr;  // cierzo.Error

// ---- Arrays and images ---------------------------------------------------------------

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

py::array_t<float> to_array(const Image& image) {
    py::array_t<float> a({py::ssize_t(image.height), py::ssize_t(image.width), py::ssize_t(3)});
    std::memcpy(a.mutable_data(), image.rgb.data(), image.rgb.size() * sizeof(float));
    return a;
}

Image to_image(const FloatArray& a, const char* what) {
    if (a.ndim() != 3 || a.shape(2) != 3)
        throw py::value_error(std::string(what) +
                              ": expected an array of shape (height, width, 3)");
    if (a.shape(0) < 1 || a.shape(1) < 1 || a.shape(0) * a.shape(1) > kMaxImagePixels)
        throw py::value_error(std::string(what) + ": the image must have 1 to 2^28 pixels");
    Image image(int(a.shape(1)), int(a.shape(0)));
    std::memcpy(image.rgb.data(), a.data(), image.rgb.size() * sizeof(float));
    return image;
}

py::object json_to_python(const nlohmann::json& j) {
    return py::module_::import("json").attr("loads")(j.dump());
}

// ---- Scenes ---------------------------------------------------------------------------

PyScene load(const py::object& source, const std::optional<fs::path>& base,
             const std::vector<fs::path>& allow_paths = {},
             const std::optional<uint64_t>& image_memory = std::nullopt) {
    if (py::isinstance<PyScene>(source)) return source.cast<PyScene>();
    LoadOptions options;
    options.allowed_paths = allow_paths;
    if (image_memory) options.image_memory = *image_memory;
    if (py::isinstance<py::dict>(source)) {
        // The same JSON as a file; relative paths resolve against `base` (default: the
        // current folder), and messages name "<dict>"
        const std::string text =
            py::module_::import("json").attr("dumps")(source).cast<std::string>();
        const fs::path path = base ? *base / "<dict>" : fs::path("<dict>");
        py::gil_scoped_release release;
        return {std::make_shared<const Scene>(parse_scene(text, path, options))};
    }
    if (base)
        throw py::type_error(
            "load_scene: base is for a dict; a file's paths resolve against its folder");
    const fs::path path = source.cast<fs::path>();
    py::gil_scoped_release release;
    return {std::make_shared<const Scene>(load_scene(path, options))};
}

// ---- Running with the GIL released, stoppable by Ctrl-C or a Cancel --------------------

// Whether a Python cancel object (cierzo.Cancel, threading.Event, anything with is_set())
// asks to stop. Called with the GIL held.
bool cancel_requested(const py::object& cancel) {
    if (cancel.is_none()) return false;
    if (py::isinstance<Cancel>(cancel)) return cancel.cast<const Cancel&>().flag->load();
    return cancel.attr("is_set")().cast<bool>();
}

// Runs `work(stop)` on a thread of its own while the calling thread, without the GIL, looks
// every 20 ms (with the GIL) for a pending signal (PyErr_CheckSignals: Ctrl-C raises
// KeyboardInterrupt there, in the main thread) and for `cancel`; either sets `stop`, which
// the render reads between passes. A signal's exception (or one raised by the cancel
// object) is raised once the work has stopped.
template <typename R>
R run_stoppable(const std::function<R(const std::atomic<bool>*)>& work, const py::object& cancel) {
    std::atomic<bool> stop{false};
    std::optional<py::error_already_set> signal_error;
    std::future<R> result;
    {
        py::gil_scoped_release release;
        result = std::async(std::launch::async, [&] { return work(&stop); });
        while (result.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
            py::gil_scoped_acquire acquire;
            if (signal_error) continue;
            try {
                if (PyErr_CheckSignals() != 0) throw py::error_already_set();
                if (!stop.load() && cancel_requested(cancel)) stop.store(true);
            } catch (py::error_already_set& e) {
                // KeyboardInterrupt (or a cancel object that failed): stop, raise it after
                signal_error.emplace(std::move(e));
                stop.store(true);
            }
        }
    }
    if (signal_error) {
        try {
            result.get();  // (a render that failed meanwhile: the signal wins)
        } catch (...) {
        }
        throw std::move(*signal_error);
    }
    return result.get();
}

// ---- Checks of keyword arguments (the command line's, named without the dashes) -------

template <typename T>
void check_range(const char* name, const std::optional<T>& v, T lo, T hi) {
    if (v && !(*v >= lo && *v <= hi))
        throw py::value_error(fmt::format("{}: value {} not in range {} to {}", name, *v, lo, hi));
}

void check_member(const char* name, const std::optional<std::string>& v,
                  const std::vector<std::string>& valid) {
    if (v && std::find(valid.begin(), valid.end(), *v) == valid.end())
        throw py::value_error(
            fmt::format("{}: '{}' not in {{{}}}", name, *v, fmt::join(valid, ", ")));
}

const std::vector<std::string> kIntegratorNames = integrator_names();
const std::vector<std::string> kIsas = {"auto", "avx512", "avx2", "sse4.2", "neon"};
const std::vector<std::string> kEstimatorNames = estimator_names();
const std::vector<std::string> kDiffuse = {"uniform", "cosine"};
const std::vector<std::string> kRouletteNames = roulette_names();
const std::vector<std::string> kTriangleSampling = {"area", "solid-angle"};
const std::vector<std::string> kSamplerNames = sampler_names();
const std::vector<std::string> kGuidingNames = guiding_names();

// ---- Render ----------------------------------------------------------------------------

py::tuple py_render(const py::object& source, std::optional<int64_t> spp, std::optional<int> width,
                    std::optional<int> height, const std::string& integrator,
                    const std::string& isa, int threads, std::optional<int64_t> seed,
                    std::optional<std::string> estimator, std::optional<float> survival_cap,
                    std::optional<std::string> diffuse_sampling,
                    std::optional<std::string> roulette, std::optional<int> roulette_depth,
                    std::optional<std::string> triangle_sampling,
                    std::optional<std::string> sampler, std::optional<std::string> guiding,
                    std::optional<int> guided_vertices, std::optional<int> min_length,
                    std::optional<int> max_length, std::optional<std::pair<int, int>> strategy,
                    bool unweighted, bool strategies, std::optional<float> merge_radius,
                    std::optional<float> merge_alpha, std::optional<int> light_connections,
                    int pool, bool variance, double time_budget, double target_error, bool progress,
                    const py::object& cancel, const std::optional<fs::path>& checkpoint,
                    std::optional<double> checkpoint_every, const std::optional<fs::path>& resume) {
    // The command line's checks of its options
    check_range<int64_t>("spp", spp, 1, UINT32_MAX);
    check_range<int>("width", width, 1, 1 << 16);
    check_range<int>("height", height, 1, 1 << 16);
    check_range<int>("threads", threads, 0, 4096);
    check_range<int64_t>("seed", seed, 0, UINT32_MAX);
    check_range<float>("survival_cap", survival_cap, 1e-6f, 0.999999f);
    check_range<int>("pool", pool, 0, 1 << 22);
    check_range<double>("time_budget", time_budget, 0.0, 1e300);
    check_range<double>("target_error", target_error, 0.0, 1e300);
    check_member("integrator", integrator, kIntegratorNames);
    check_member("isa", isa, kIsas);
    check_member("estimator", estimator, kEstimatorNames);
    check_member("diffuse_sampling", diffuse_sampling, kDiffuse);
    check_member("roulette", roulette, kRouletteNames);
    check_range<int>("roulette_depth", roulette_depth, 0, kMaxRouletteDepth);
    check_member("triangle_sampling", triangle_sampling, kTriangleSampling);
    check_member("sampler", sampler, kSamplerNames);
    check_member("guiding", guiding, kGuidingNames);
    check_range<int>("guided_vertices", guided_vertices, 0, kMaxLengthLimit);
    check_range<int>("min_length", min_length, 1, kMaxLengthLimit);
    check_range<int>("max_length", max_length, 1, kMaxLengthLimit);
    check_range<double>("checkpoint_every", checkpoint_every, 0.01, 1e9);
    if (resume && !fs::is_regular_file(*resume))
        throw InputError(resume->string() + ": no such checkpoint file");

    RenderJob job;
    job.spp = spp;
    if (seed) job.seed = uint32_t(*seed);
    job.width = width, job.height = height;
    job.survival_cap = survival_cap;
    job.diffuse_sampling = diffuse_sampling;
    job.roulette = roulette;
    job.roulette_depth = roulette_depth;
    job.triangle_sampling = triangle_sampling;
    job.sampler = sampler;
    job.guiding = guiding;
    job.guided_vertices = guided_vertices;
    job.min_length = min_length, job.max_length = max_length;
    if (strategy) job.strategy = {strategy->first, strategy->second};
    job.unweighted = unweighted;
    job.strategies = strategies;
    job.integrator_given = integrator != std::string(integrator_name(Integrator::kWavefront));
    job.merge_radius = merge_radius, job.merge_alpha = merge_alpha;
    job.light_connections = light_connections;
    job.estimator = estimator;
    job.threads = threads;
    job.integrator = integrator;
    job.isa = isa;
    job.pool = pool;
    job.time_budget = time_budget;
    job.target_error = target_error;
    job.progress = progress;
    job.write_outputs = false;
    if (checkpoint) job.checkpoint = *checkpoint;
    if (resume) job.resume = *resume;
    job.checkpoint_every_given = checkpoint_every.has_value();
    job.checkpoint_every = checkpoint_every.value_or(300.0);
    check_render_isa(job);
    const PyScene scene = load(source, std::nullopt);

    const RenderJobResult done = run_stoppable<RenderJobResult>(
        [&](const std::atomic<bool>* stop) {
            RenderJob j = job;
            j.cancel = stop;
            return run_render_job(*scene.scene, j);
        },
        cancel);
    const RenderStats& st = done.result.stats;
    py::object stats = json_to_python(render_stats_json(done.scene, st, done.checkpoint));
    py::array_t<float> image = to_array(done.result.film.mean());
    py::list out;
    out.append(image);
    if (variance) out.append(to_array(done.result.film.variance_of_mean()));
    out.append(stats);
    if (done.strategies) {
        // {(s, t): {'weighted': image, 'unweighted': image}}
        py::dict images;
        const StrategyFilm& f = *done.strategies;
        for (int i = 0; i < f.layout().count(); ++i) {
            int s = 0, t = 0;
            f.layout().strategy(i, s, t);
            py::dict pair;
            pair["weighted"] = to_array(f.image(i, true, st.spp_reached));
            pair["unweighted"] = to_array(f.image(i, false, st.spp_reached));
            images[py::make_tuple(s, t)] = pair;
        }
        out.append(images);
    }
    return py::tuple(out);
}

// ---- Converge --------------------------------------------------------------------------

// A CSV field as Python reads it: an int, a float, or the text.
py::object csv_value(const std::string& field) {
    int64_t i = 0;
    const char* end = field.data() + field.size();
    if (auto [p, ec] = std::from_chars(field.data(), end, i); ec == std::errc() && p == end)
        return py::int_(i);
    double d = 0;
    if (auto [p, ec] = std::from_chars(field.data(), end, d); ec == std::errc() && p == end)
        return py::float_(d);
    return py::str(field);
}

std::vector<std::string> split_csv(const std::string& line) {
    std::vector<std::string> out;
    size_t start = 0;
    for (size_t comma; (comma = line.find(',', start)) != std::string::npos; start = comma + 1)
        out.push_back(line.substr(start, comma - start));
    out.push_back(line.substr(start));
    return out;
}

py::list py_converge(
    const py::object& source, const std::optional<fs::path>& reference, int64_t reference_spp,
    const std::string& reference_integrator, const std::optional<fs::path>& save_reference,
    const std::vector<int64_t>& spp, const std::vector<std::string>& integrator,
    const std::vector<std::string>& isa, const std::vector<int>& pool,
    const std::vector<float>& survival_cap, const std::vector<std::string>& diffuse_sampling,
    const std::vector<std::string>& roulette, std::optional<int> roulette_depth,
    const std::vector<std::string>& triangle_sampling, const std::vector<std::string>& sampler,
    const std::vector<std::string>& guiding, std::optional<int> guided_vertices,
    const std::vector<std::string>& estimator, const std::vector<float>& merge_radius,
    const std::vector<float>& merge_alpha, const std::vector<int>& light_connections,
    std::optional<std::string> reference_estimator, std::optional<int> width,
    std::optional<int> height, int threads, int repeats, const std::optional<fs::path>& out,
    bool verbose, const py::object& cancel) {
    check_range<int64_t>("reference_spp", reference_spp, 1, UINT32_MAX);
    check_member("reference_integrator", reference_integrator, kIntegratorNames);
    for (int64_t v : spp) check_range<int64_t>("spp", v, 1, UINT32_MAX);
    for (const std::string& v : integrator) check_member("integrator", v, kIntegratorNames);
    for (const std::string& v : isa) check_member("isa", v, kIsas);
    for (int v : pool) check_range<int>("pool", v, 0, 1 << 22);
    for (float v : survival_cap) check_range<float>("survival_cap", v, 1e-6f, 0.999999f);
    for (const std::string& v : diffuse_sampling) check_member("diffuse_sampling", v, kDiffuse);
    for (const std::string& v : roulette) check_member("roulette", v, kRouletteNames);
    check_range<int>("roulette_depth", roulette_depth, 0, kMaxRouletteDepth);
    for (const std::string& v : triangle_sampling)
        check_member("triangle_sampling", v, kTriangleSampling);
    for (const std::string& v : sampler) check_member("sampler", v, kSamplerNames);
    for (const std::string& v : guiding) check_member("guiding", v, kGuidingNames);
    check_range<int>("guided_vertices", guided_vertices, 0, kMaxLengthLimit);
    for (const std::string& v : estimator) check_member("estimator", v, kEstimatorNames);
    for (float v : merge_radius)
        if (!(v > 0.0f) || !std::isfinite(v))
            throw py::value_error("merge_radius: each must be a positive length");
    for (float v : merge_alpha)
        if (!(v > 0.0f && v < 1.0f))
            throw py::value_error("merge_alpha: each must be in (0, 1), exclusive");
    for (int v : light_connections)
        check_range<int>("light_connections", v, 0, kMaxLightConnections);
    check_member("reference_estimator", reference_estimator, kEstimatorNames);
    check_range<int>("width", width, 1, 1 << 16);
    check_range<int>("height", height, 1, 1 << 16);
    check_range<int>("threads", threads, 0, 4096);
    check_range<int>("repeats", repeats, 1, 1000);
    if (spp.empty() || integrator.empty() || isa.empty() || pool.empty())
        throw py::value_error("converge: spp, integrator, isa and pool need one value at least");
    if (reference && save_reference)
        throw py::value_error(
            "converge: save_reference is for a rendered reference, not with reference");

    ConvergeArgs a;
    if (reference) a.reference = *reference;
    if (save_reference) a.save_reference = *save_reference;
    a.reference_spp = reference_spp;
    a.reference_integrator = reference_integrator;
    a.spp = spp;
    a.integrators = integrator;
    a.isas = isa;
    a.pools = pool;
    a.survival_caps = survival_cap;
    a.diffuse_sampling = diffuse_sampling;
    a.roulettes = roulette;
    a.roulette_depth = roulette_depth;
    a.triangle_sampling = triangle_sampling;
    a.samplers = sampler;
    a.guidings = guiding;
    a.guided_vertices = guided_vertices;
    a.estimators = estimator;
    a.merge_radii = merge_radius, a.merge_alphas = merge_alpha;
    a.light_connections = light_connections;
    a.reference_estimator = reference_estimator;
    a.width = width, a.height = height;
    a.threads = threads;
    a.repeats = repeats;
    if (out) a.out = *out;
    a.quiet = !verbose;
    a.summary = verbose;
    const PyScene scene = load(source, std::nullopt);
    a.scene = scene.scene->source;

    const std::vector<std::string> rows = run_stoppable<std::vector<std::string>>(
        [&](const std::atomic<bool>* stop) {
            ConvergeArgs args = a;
            args.cancel = stop;
            return run_converge_job(*scene.scene, args);
        },
        cancel);
    const std::vector<std::string> columns = split_csv(converge_csv_header());
    py::list result;
    for (const std::string& row : rows) {
        const std::vector<std::string> fields = split_csv(row);
        py::dict d;
        for (size_t i = 0; i < columns.size() && i < fields.size(); ++i)
            d[py::str(columns[i])] = csv_value(fields[i]);
        result.append(d);
    }
    return result;
}

// ---- Tone mapping ------------------------------------------------------------------------

py::array_t<float> tonemap_array(const FloatArray& array, const std::string& op, float exposure,
                                 float gamma, std::optional<float> clamp) {
    const Image image = to_image(array, "tonemap");
    TonemapOptions options;
    options.op = op;
    options.exposure = exposure;
    options.gamma = gamma;
    options.clamp = clamp;
    Image out;
    {
        py::gil_scoped_release release;
        out = tonemap(image, options);
    }
    return to_array(out);
}

}  // namespace

PYBIND11_MODULE(cierzo, m) {
    m.doc() = R"(cierzo: a research path tracer for CPUs.

Scenes are the JSON of scene files (docs/scene-format.md), read from a file or given as a
dict. Renders run the code of `cierzo render` and `cierzo converge`: keyword arguments
override the scene as the command line's options do, and the same scene and seed give the
same image, bit for bit. Images are float32 NumPy arrays of shape (height, width, 3), row 0
at the top. Errors about the input raise cierzo.Error (a ValueError and an OSError) with the
command line's messages; bad keyword values raise ValueError.

Functions: load_scene, render, converge, read_exr, write_exr, write_ldr, tonemap,
tonemap_operators, isas. Classes: Scene, Cancel, Error.)";
    m.attr("__version__") = "0.1";

    g_error = PyErr_NewExceptionWithDoc(
        "cierzo.Error",
        "An error in cierzo's input: a malformed scene or image, a bad value in it, a file that "
        "cannot be read or written. The message is the command line's: it names the file (a "
        "scene given as a dict is '<dict>') and the problem.",
        py::make_tuple(py::handle(PyExc_ValueError), py::handle(PyExc_OSError)).release().ptr(),
        nullptr);
    m.attr("Error") = py::handle(g_error);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const InputError& e) {
            PyErr_SetString(g_error, e.what());
        }
    });

    py::class_<PyScene>(m, "Scene",
                        "A scene as read by load_scene: geometry, materials, lights, camera and "
                        "render settings. Renders never change it.")
        .def_property_readonly("width", [](const PyScene& s) { return s.scene->settings.width; })
        .def_property_readonly("height", [](const PyScene& s) { return s.scene->settings.height; })
        .def_property_readonly(
            "spp", [](const PyScene& s) { return s.scene->settings.spp; },
            "Paths per pixel (render.spp)")
        .def_property_readonly("seed", [](const PyScene& s) { return s.scene->settings.seed; })
        .def_property_readonly(
            "estimator",
            [](const PyScene& s) { return estimator_name(s.scene->settings.estimator.kind); })
        .def_property_readonly(
            "source", [](const PyScene& s) { return s.scene->source.string(); },
            "The file it was read from ('<dict>' for a dict)")
        .def("__repr__", [](const PyScene& s) {
            const RenderSettings& r = s.scene->settings;
            return fmt::format("<cierzo.Scene '{}' {}x{}, {} spp, seed {}>",
                               s.scene->source.string(), r.width, r.height, r.spp, r.seed);
        });

    py::class_<Cancel>(m, "Cancel",
                       "Stops a render or sweep from another thread: pass it as cancel=, then "
                       "call cancel() (a threading.Event works too).")
        .def(py::init<>())
        .def(
            "cancel", [](Cancel& c) { c.flag->store(true); },
            "Ask the render to stop at the end of its pass in progress")
        .def("is_set", [](const Cancel& c) { return c.flag->load(); })
        .def("clear", [](Cancel& c) { c.flag->store(false); });

    m.def("load_scene", &load, py::arg("source"), py::arg("base") = py::none(), py::kw_only(),
          py::arg("allow_paths") = std::vector<fs::path>{}, py::arg("image_memory") = py::none(),
          R"(Reads a scene: a path to a scene file (str or os.PathLike), or a dict holding the
same JSON as a file. Relative paths in a file (meshes, output) resolve against the file's
folder; in a dict, against `base` if given, else the current folder. The files a scene
names must lie beneath that folder or one of `allow_paths` (the command line's
--allow-path), and its images may take at most `image_memory` bytes while decoded (the
command line's --image-memory; default 4 GiB or half the machine's memory). Messages about a
dict name it '<dict>'. Raises cierzo.Error with the command line's message.)");

    m.def("render", &py_render, py::arg("scene"), py::kw_only(), py::arg("spp") = py::none(),
          py::arg("width") = py::none(), py::arg("height") = py::none(),
          py::arg("integrator") = std::string(integrator_name(Integrator::kWavefront)),
          py::arg("isa") = "auto", py::arg("threads") = 0, py::arg("seed") = py::none(),
          py::arg("estimator") = py::none(), py::arg("survival_cap") = py::none(),
          py::arg("diffuse_sampling") = py::none(), py::arg("roulette") = py::none(),
          py::arg("roulette_depth") = py::none(), py::arg("triangle_sampling") = py::none(),
          py::arg("sampler") = py::none(), py::arg("guiding") = py::none(),
          py::arg("guided_vertices") = py::none(), py::arg("min_length") = py::none(),
          py::arg("max_length") = py::none(), py::arg("strategy") = py::none(),
          py::arg("unweighted") = false, py::arg("strategies") = false,
          py::arg("merge_radius") = py::none(), py::arg("merge_alpha") = py::none(),
          py::arg("light_connections") = py::none(), py::arg("pool") = 0,
          py::arg("variance") = false, py::arg("time_budget") = 0.0, py::arg("target_error") = 0.0,
          py::arg("progress") = false, py::arg("cancel") = py::none(),
          py::arg("checkpoint") = py::none(), py::arg("checkpoint_every") = py::none(),
          py::arg("resume") = py::none(),
          R"(Renders a scene (a Scene, a path or a dict) as `cierzo render` does.

Returns (image, stats), or (image, variance, stats) with variance=True: float32 arrays of
shape (height, width, 3), the mean and the variance of each pixel's mean, and the dict of
`cierzo render --stats` (same keys). With strategies=True (bdpt) a last element is added:
{(s, t): {'weighted': image, 'unweighted': image}}, every strategy of paths up to
max_length segments (default 5, at most 12), as `cierzo render --strategies DIR` writes
them; the render is then the scalar integrator's (integrator must be left at its default
or be 'scalar'). Keywords left at None keep the scene's value:
  spp, width, height, seed, estimator ('report', 'nee', 'mis', 'lt', 'bdpt', 'vcm',
  'bpm', 'ppm'),
  survival_cap (0..1),
  diffuse_sampling ('uniform', 'cosine'), roulette ('lobe', or 'throughput' for nee and
  mis), roulette_depth (the vertex the throughput roulette starts at, 0..1024),
  triangle_sampling ('area', 'solid-angle': how nee and mis sample emitting triangles),
  sampler ('independent', 'sobol', 'zsobol', 'pmj02': where the random numbers come from),
  guiding ('none', 'sdtree': nee and mis; with min_length or max_length, the scalar
  integrator), guided_vertices (the Phong vertices of a camera path the guide serves, from
  the camera; 0: every one),
  min_length, max_length (only paths of that many segments count: 1 is the camera seeing an
  emitter, 2 direct light; 1..1048576);
  strategy (bdpt: a pair (s, t), only the paths of s light and t camera vertices count, with
  their MIS weight, or with unweighted=True without it); merge_radius, merge_alpha (vcm, bpm, ppm:
  the first sample's merging radius r0 > 0, scene units, and alpha in (0, 1); sample n
  merges within r0 * (n + 1)^((alpha - 1) / 2)); light_connections (bdpt, vcm: 0 connects
  a camera vertex to every vertex of its sample's own light subpath, n in 1..64 to n vertices
  drawn from the light vertex cache; default 1);
and as the command line's options: integrator 'wavefront' or 'scalar', isa 'auto', 'avx512',
'avx2', 'sse4.2' or 'neon', threads (0 = every CPU), pool (wavefront paths per thread, a
multiple of 16; 0 = 512), time_budget (seconds, 0 = none) and target_error (mean relative
standard error, 0 = none), which stop at the end of a pass; progress prints the progress
line on stderr.

The GIL is released while rendering. Ctrl-C stops the render at the end of its first pass
at the earliest and raises KeyboardInterrupt. cancel (a cierzo.Cancel, a threading.Event or
anything with is_set()) stops it the same way from another thread, and render returns the
passes finished: stats['stopped_by'] is then 'interrupted' and stats['spp_reached'] says how
many paths every pixel has.

checkpoint (a path ending in .exr) writes the render's exact state every checkpoint_every
seconds (default 300), when stopped and at the end; resume continues such a file to spp
paths per pixel, and the image is then the same, bit for bit, as an uninterrupted render's,
as with `cierzo render --checkpoint/--resume` (a checkpoint of another scene, resolution,
seed, estimator or integrator is refused).)");

    m.def("converge", &py_converge, py::arg("scene"), py::kw_only(),
          py::arg("reference") = py::none(), py::arg("reference_spp") = 4096,
          py::arg("reference_integrator") = ConvergeArgs{}.reference_integrator,
          py::arg("save_reference") = py::none(),
          py::arg("spp") = std::vector<int64_t>{1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024},
          py::arg("integrator") = ConvergeArgs{}.integrators,
          py::arg("isa") = std::vector<std::string>{"auto"}, py::arg("pool") = std::vector<int>{0},
          py::arg("survival_cap") = std::vector<float>{},
          py::arg("diffuse_sampling") = std::vector<std::string>{},
          py::arg("roulette") = std::vector<std::string>{}, py::arg("roulette_depth") = py::none(),
          py::arg("triangle_sampling") = std::vector<std::string>{},
          py::arg("sampler") = std::vector<std::string>{},
          py::arg("guiding") = std::vector<std::string>{}, py::arg("guided_vertices") = py::none(),
          py::arg("estimator") = std::vector<std::string>{},
          py::arg("merge_radius") = std::vector<float>{},
          py::arg("merge_alpha") = std::vector<float>{},
          py::arg("light_connections") = std::vector<int>{},
          py::arg("reference_estimator") = py::none(), py::arg("width") = py::none(),
          py::arg("height") = py::none(), py::arg("threads") = 0, py::arg("repeats") = 1,
          py::arg("out") = py::none(), py::arg("verbose") = false, py::arg("cancel") = py::none(),
          R"(Error against time, as `cierzo converge` measures it (see its --help).

Renders (or reads, reference=PATH to an .exr or .pfm) a reference, then the scene at each
paths-per-pixel count of spp for every combination of integrator, isa, pool, survival_cap,
diffuse_sampling, roulette, triangle_sampling, sampler and estimator, for nee and mis guiding,
and for vcm, bpm and ppm
merge_radius and merge_alpha, for bdpt and vcm light_connections (lists; an empty list
keeps the scene's value; roulette_depth and guided_vertices one value or None). Returns one
dict per render, keyed by the CSV's columns (scene, integrator, isa, pool, survival_cap, diffuse_sampling, roulette ('lobe', or e.g.
'throughput3': from vertex 3), triangle_sampling, sampler, estimator, merge_radius and
merge_alpha (vcm's, bpm's and ppm's, as rendered; empty for the others), light_connections
(bdpt's and vcm's; empty for the others), guiding ('none', or e.g. 'sdtree1': the guide
serving the first Phong vertex), threads, width, height, spp, repeats, seconds, rays,
rays_per_second, mse, rmse, rel_mse, reference_mse, reference_rel_mse, mse_corrected,
rmse_corrected, rel_mse_corrected, estimated_relative_error, efficiency). out writes the
same rows as CSV, save_reference the rendered reference (.exr); verbose prints the table and
summary of the command. Ctrl-C raises KeyboardInterrupt; cancel stops and returns the rows
measured so far.)");

    m.def(
        "read_exr",
        [](const fs::path& path, bool metadata, bool variance) -> py::object {
            ImageMetadata meta;
            ImageLayers layers;
            Image image, v;
            {
                py::gil_scoped_release release;
                image = read_exr(path, &meta, &layers);
                if (variance) v = variance_from_layers(layers, image.width, image.height, path);
            }
            py::list out;
            out.append(to_array(image));
            if (variance) out.append(to_array(v));
            if (metadata) out.append(py::cast(meta));
            if (out.size() == 1) return out[0];
            return py::tuple(out);
        },
        py::arg("path"), py::arg("metadata") = false, py::arg("variance") = false,
        R"(Reads an OpenEXR image's R, G, B channels as a float32 array (height, width, 3).
With variance=True also its variance.R/G/B layers (as `render --variance` and write_exr
write them) as an array of the same shape, and with metadata=True the dict of the header's
string attributes (e.g. 'cierzo:spp'): returns (image[, variance][, metadata]). Raises
cierzo.Error naming the file (a missing layer too).)");
    m.def(
        "write_exr",
        [](const fs::path& path, const FloatArray& array, const ImageMetadata& metadata,
           const std::optional<FloatArray>& variance) {
            const Image image = to_image(array, "write_exr");
            ImageLayers layers;
            if (variance) {
                const Image v = to_image(*variance, "write_exr: variance");
                if (v.width != image.width || v.height != image.height)
                    throw py::value_error("write_exr: the variance must have the image's shape");
                layers = variance_layers(v);
            }
            py::gil_scoped_release release;
            // The program's refusals (a folder that does not exist, a folder, a block device)
            check_outputs({{path, "path", "the image"}}, {});
            write_exr(path, image, metadata, layers);
        },
        py::arg("path"), py::arg("image"), py::arg("metadata") = ImageMetadata{},
        py::arg("variance") = py::none(),
        R"(Writes a (height, width, 3) array as a float32 OpenEXR file (lossless), with the
given string attributes in its header and, if given, a variance array as the layers
variance.R/G/B that `cierzo render --variance` writes (and `converge` reads from a
reference). As every output of cierzo: an existing file is replaced only once the new one is
complete, a symbolic link is written through to its target, and a device or FIFO is written
directly. Raises cierzo.Error with the program's message when it cannot be written.)");
    m.def(
        "write_ldr",
        [](const fs::path& path, const FloatArray& array) {
            const Image image = to_image(array, "write_ldr");
            py::gil_scoped_release release;
            check_outputs({{path, "path", "the image"}}, {});
            write_ldr(path, image);
        },
        py::arg("path"), py::arg("image"),
        R"(Writes an already tone-mapped array (values in [0, 1], clamped, rounded to 8 bits)
as .png, .ppm or .bmp, chosen by the extension; written as write_exr writes.)");
    m.def("tonemap", &tonemap_array, py::arg("image"), py::kw_only(), py::arg("op") = "gamma",
          py::arg("exposure") = 0.0f, py::arg("gamma") = 2.2f, py::arg("clamp") = py::none(),
          R"(Tone-maps a linear (height, width, 3) array into display values in [0, 1], as
cierzo-tonemap does: x = max(v, 0) * 2^exposure per component (NaN and Inf count as 0), then
the operator op: clamp, equalize, equalize-clamp, gamma, clamp-gamma or reinhard (formulas
in tonemap_operators() and docs/tonemap.md). gamma is G of gamma and clamp-gamma; clamp is
V of clamp, equalize-clamp and clamp-gamma (None = 1). Raises cierzo.Error for a bad value.)");
    m.def(
        "tonemap_operators",
        [] {
            py::dict d;
            for (const TonemapOperatorInfo& info : tonemap_operators())
                d[py::str(info.name)] = info.formula;
            return d;
        },
        "The operators of tonemap(op=...) and of cierzo-tonemap, as a dict name: formula "
        "(docs/tonemap.md derives them).");
    m.def(
        "isas",
        [] {
            py::list out;
            const Isa best = best_isa();
            for (Isa isa : compiled_isas()) {
                py::dict d;
                d["name"] = isa_name(isa);
                d["lanes"] = isa_width(isa);
                d["supported"] = isa_supported(isa);
                d["auto"] = isa == best;
                d["reason"] = isa_unsupported_reason(isa);
                out.append(d);
            }
            return out;
        },
        "The wavefront's instruction sets in this build, as `cierzo isas` lists them: name, "
        "lanes, whether this CPU runs it, whether isa='auto' picks it, and why not.");
}
