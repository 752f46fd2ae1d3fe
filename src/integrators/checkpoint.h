// Checkpoints: a render's state in an OpenEXR file, so a long render survives a crash, a
// pre-empted node or a full disk, and can be continued to the same image bit for bit.
//
// The file is an ordinary EXR (its R, G, B are the image so far, for any viewer) with the
// exact state beside them: each pixel's sums, sums of squares and path counts as the bit
// patterns of their doubles and 64-bit integers in UINT channels (hi and lo words), for the
// film of the passes done and for the tiles done of the pass in progress ("pending."), and
// in its header what the state belongs to (the scene's fingerprint, resolution, seed,
// estimator, integrator), how far it got, a guided render's path guide, and a 64-bit checksum
// of all of that and of every channel's words. Written atomically: a failed write leaves the
// previous checkpoint as it was. Read as strictly as a scene: the header's sizes before
// OpenEXR parses it, then the checksum, then every value (sums finite and >= 0, each pixel
// holding the paths the header says, the guide within its bounds).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "integrators/render_types.h"
#include "io/image.h"
#include "scene/scene.h"

namespace cierzo {

// What a render's pixels depend on, recorded in its checkpoint and compared on resume.
struct CheckpointIdentity {
    std::string scene;        // the scene file, for messages
    std::string fingerprint;  // of the scene's content (scene_fingerprint)
    int width = 0, height = 0;
    uint32_t seed = 0;
    std::string estimator;          // report, nee, mis
    std::string survival_cap;       // exact, as %a
    std::string roulette;           // "lobe", or "throughput from N" (its depth)
    std::string sampler;            // its name; zsobol with its block of 2^L paths per pixel
    std::string lengths;            // the path lengths that count: "1..", "2..3"
    std::string triangle_sampling;  // "area" or "solid-angle"
    std::string diffuse_sampling;   // uniform, cosine
    std::string integrator;         // wavefront, scalar
    std::string isa;                // the wavefront's kernels (the order of each pixel's sums)
    int pool = 0;                   // wavefront paths per thread (the same)
    int64_t spp = 0;                // the paths per pixel asked for
};

// A 64-bit hash (hex) of everything in the scene that is not a render setting: the scene
// file without its "render" block, and the geometry and colours of every mesh as loaded.
std::string scene_fingerprint(const Scene& scene);

CheckpointIdentity checkpoint_identity(const Scene& scene, const std::string& integrator,
                                       const std::string& isa, int pool);

void write_checkpoint(const std::filesystem::path& path, const CheckpointIdentity& id,
                      const RenderState& state);

struct Checkpoint {
    CheckpointIdentity id;
    RenderState state;
};

// Reads a checkpoint; an InputError names the file and what is wrong (not a checkpoint, of
// an older cierzo, truncated, a checksum mismatch, a value out of range, inconsistent
// counts). A file read is the state written, bit for bit.
Checkpoint read_checkpoint(const std::filesystem::path& path);

// Refuses (InputError naming the file and every difference) a checkpoint of another scene,
// resolution, seed, estimator or integrator. Returns warnings for what keeps the image right
// but not bit-identical (other kernels or pool size).
std::vector<std::string> check_resume(const std::filesystem::path& path, const Checkpoint& c,
                                      const CheckpointIdentity& now);

}  // namespace cierzo
