// The scalar reference path tracer: one path at a time, depth first, exactly the report's
// estimator. It is the oracle the wavefront kernels are checked against, and the baseline
// they are measured against.
#pragma once

#include "integrators/render_types.h"

namespace cierzo {

class PathGuide;

// The radiance carried back along one camera path whose numbers are the independent
// sampler's for path key `key` (kernels/rng.h).
Vec3f trace_path(const Scene& scene, const Ray<float>& camera_ray, uint32_t key, RayCounts& rays);
// The same with the scene's path context (Scene::path_context) computed once by the caller,
// and the path's numbers from the sampler's stream of its (seed, pixel, sample)
// (kernels/sampler.h, camera_stream). A guided render's paths sample from context.guide and
// deposit their records in `learn` (path_guide.h) as paths of pass `pass`.
Vec3f trace_path(const Scene& scene, const PathContext& context, const Ray<float>& camera_ray,
                 const SampleStream<float>& rng, RayCounts& rays, PathGuide* learn = nullptr,
                 int32_t pass = 0);

// One path from the lights (light tracing), with the numbers of the camera sample whose
// stream it takes (light_stream): every connection to the pinhole that nothing blocks is
// splatted into `film`.
void trace_light_path(const Scene& scene, const PathContext& context, const PinholeFrame& pinhole,
                      const SampleStream<float>& camera_rng, FilmTile& film, RayCounts& rays);

// Samples [tile.s0, tile.s1) of the tile's pixels, added to the tile's sums; for a batch of
// light paths (tile.light), one path from the lights per key of those pixels and samples,
// splatted. `guide`: a guided render's path guide (path_guide.h), which its camera paths
// sample from (once trained) and learn into, as paths of pass `pass`.
void render_tile_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays,
                        PathGuide* guide = nullptr, int32_t pass = 0);

// The same for the bidirectional estimators (scalar_bdpt.cpp): each sample's light subpath,
// its connections to the pinhole splatted, then its camera subpath with every connection.
// The light vertices kept at once (one sample's, or with vcm a tile's sample's) may take at
// most `light_store_limit` bytes (refuse_light_store).
void render_tile_bdpt_scalar(const Scene& scene, const Tile& tile, FilmTile& film, RayCounts& rays,
                             size_t light_store_limit = kLightStoreLimit);

// The mean number of vertices a light subpath of the scene stores (bdpt's and vcm's Phong
// vertices), over `paths` light subpaths traced as the render's are, with the estimator
// settings of `context` but independent numbers of a fixed seed (kLightPilotSeed): the same
// answer for every render, thread count, rank and resume of the scene with these settings.
// 0 when the scene has no light to start from.
double light_subpath_vertices(const Scene& scene, const PathContext& context, int32_t paths);

}  // namespace cierzo
