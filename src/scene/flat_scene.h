// The scene as the per-ISA wavefront kernels see it: plain arrays and counts, no kernel types,
// no standard containers, so the per-ISA objects share no inline code with the rest of the
// program. It is a view of the one Scene (scene.h): the BVH, the meshes' vertices, the
// emitters and the light starts are the scene's own; the tables of 16 lanes the SIMD loads
// need (padded primitives and materials, values repeated in lanes) are built once with the
// scene (Scene::finalize, flat_tables.h).
#pragma once

#include <cstdint>

#include "kernels/bvh/bvh_layout.h"
#include "kernels/emitter_table.h"
#include "kernels/prim_id.h"

namespace cierzo {

// Every per-primitive and per-material table is padded to a multiple of 16 entries, so a
// whole SIMD register can be loaded from it.

// The colour channels of a material, in this order.
enum MaterialColor : int { kColEmission = 0, kColKd, kColKs, kColKr, kColKt, kColCount };

// One colour source, flattened (same meaning as ColorSource in kernels/texture.h).
struct FlatColor {
    uint32_t kind;  // TextureKind
    float a[3], b[3];
    float frequency;
    float axis[3], axis2[3];
    int32_t image;  // image textures: the scene's image, the texture-coordinate map, the wrap
    float uv_scale[2], uv_offset[2];
    uint32_t clamp;
};

// An image texture (same meaning as ImageView in kernels/texture.h).
struct FlatImage {
    const int32_t* bytes;
    const float* floats;
    const float* decode;
    int32_t width, height;
};

// A mesh object as the vertex-colour evaluation reads it: its triangles' vertex indices,
// positions and colours (those of the geometry it instances), and for an instance the
// world-to-object map (its vertices are in the file's space).
struct FlatMesh {
    const int32_t* indices = nullptr;        // 3 vertex indices per triangle
    const float* positions = nullptr;        // x, y, z per vertex
    const float* colors = nullptr;           // r, g, b per vertex; null when the mesh has none
    const float* to_object = nullptr;        // row-major 3 × 4; null for world-space vertices
    const float* normals = nullptr;          // x, y, z per vertex; null unless the object is smooth
    const float* normal_to_world = nullptr;  // row-major 3 × 3, for an instance's normals
    const float* uvs = nullptr;              // u, v per vertex; null when the mesh has none
};

// Which stages and primitive loops a scene needs; the kernels skip everything else.
struct FlatFeatures {
    bool spheres, planes, quadrics, meshes;
    bool bvh;     // anything bounded: the scene BVH is traversed
    bool packet;  // the BVH is one node, tested K rays at a time (kernels/bvh/traverse.h)
    bool lights, emitters;
    bool diffuse, specular, mirror, refraction;
    bool textures;   // procedural or vertex colours anywhere: materials are sorted and evaluated
    int lobe_kinds;  // how many of the four lobes occur (1: no lobe bucketing needed)
    uint32_t texture_channels;  // bit c: some material textures colour channel c
    // (whether the estimator samples emitters, traces light paths, and whether some mesh is
    // smooth: FlatScene::path, the one place the stages read them from)
};

struct FlatScene {
    // Spheres, planes (n·p + d = 0), quadrics (10 coefficients + box min + box max)
    int32_t sphere_count;
    const float *sphere_cx, *sphere_cy, *sphere_cz, *sphere_r;
    const int32_t* sphere_material;
    int32_t plane_count;
    const float *plane_nx, *plane_ny, *plane_nz, *plane_d;
    const int32_t* plane_material;
    // The same four values of each plane (nx, ny, nz, d), each repeated in 16 lanes, 64-byte
    // aligned: the intersection loop reads them as whole vectors, an operand of the
    // arithmetic instead of a broadcast per batch
    const float* plane_lanes;  // 4 * 16 per plane
    int32_t quadric_count;
    const float* quadric;        // 16 floats each: A..J, box min xyz, box max xyz
    const float* quadric_lanes;  // the same 16 values, each repeated in 16 lanes
    const int32_t* quadric_material;
    int32_t unbounded_quadric_count;    // the quadrics without a finite box, tested beside
    const int32_t* unbounded_quadrics;  // the BVH: their indices
    const BvhView* bvh;                 // everything bounded
    const AlphaTable* alpha;            // the meshes' alpha cut-outs, or null (none)
    int32_t mesh_count;
    const int32_t* mesh_material;
    const FlatMesh* meshes;

    // Materials: solid colours as SoA [channel][component][material], flags, sources
    int32_t material_count;
    int32_t material_stride;   // material_count rounded up to 16 (tables are padded)
    const float* color;        // kColCount * 3 * material_stride
    const float* shininess;    // material_count
    const float* ior;          // material_count
    const int32_t* emitter;    // material_count, 1 if the material emits (ends paths)
    const int32_t* phong;      // material_count, 1 if kd or ks is non-zero
    const int32_t* textured;   // material_count, bit c set if colour channel c is not solid
    const FlatColor* sources;  // material_count * kColCount
    const FlatImage* images;   // the image textures the sources name

    // Point lights: position xyz, intensity rgb
    int32_t light_count;
    const float* light;

    // The emitter (of path.emitters, kernels/emitter_table.h) of each sphere and the first
    // of each mesh (-1: not sampled)
    const int32_t* sphere_emitter;
    const int32_t* mesh_emitter;

    // Camera frame and image
    float cam_origin[3], cam_forward[3], cam_left[3], cam_up[3];
    int32_t width, height;
    uint32_t seed;
    // What a path vertex needs (kernels/path_vertex.h): the emitters, the estimator's
    // settings, the point lights, the scene's index, as the scalar reference has them
    PathContext path;
    // Light tracing: where light paths start and the pinhole they connect to; and whether
    // camera tiles trace camera paths (always, but under light tracing only where some
    // emitter cannot be sampled)
    LightStartTable light_starts;
    PinholeFrame pinhole;
    bool camera_paths;  // Scene::traces_camera_paths
    FlatFeatures features;
    // How many rays a thread keeps in flight through the tree (kernels/bvh/traverse_group.h;
    // 1, the default: one at a time), the renderer's choice
    int32_t ray_group;
};

}  // namespace cierzo
