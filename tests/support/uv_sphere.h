// A latitude/longitude sphere mesh with shared vertices and fans at the poles, for tests and
// benchmarks: 2 · segments · (rings − 1) triangles, optionally displaced radially.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "kernels/vec3.h"

namespace cierzo::test {

struct TriangleMesh {
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;
};

// radius(theta, phi) scales each vertex (1 when not given).
inline TriangleMesh uv_sphere(int rings, int segments,
                              const std::function<float(float, float)>& radius = {}) {
    const float pi = 3.14159265358979f;
    const auto point = [&](float theta, float phi) {
        const float r = radius ? radius(theta, phi) : 1.0f;
        return Vec3f(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                     std::cos(theta)) *
               r;
    };
    TriangleMesh mesh;
    // Vertices: the poles and the rings between them
    mesh.positions.push_back(point(0.0f, 0.0f));
    for (int r = 1; r < rings; ++r)
        for (int s = 0; s < segments; ++s)
            mesh.positions.push_back(
                point(pi * float(r) / float(rings), 2.0f * pi * float(s) / float(segments)));
    mesh.positions.push_back(point(pi, 0.0f));
    // Triangles: fans at the poles, two per quad in between
    const uint32_t south = uint32_t(mesh.positions.size() - 1);
    const auto ring = [&](int r, int s) { return uint32_t(1 + (r - 1) * segments + s % segments); };
    for (int s = 0; s < segments; ++s) {
        mesh.indices.insert(mesh.indices.end(), {0u, ring(1, s), ring(1, s + 1)});
        mesh.indices.insert(mesh.indices.end(),
                            {south, ring(rings - 1, s + 1), ring(rings - 1, s)});
    }
    for (int r = 1; r + 1 < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            mesh.indices.insert(mesh.indices.end(),
                                {ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)});
            mesh.indices.insert(mesh.indices.end(),
                                {ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)});
        }
    }
    return mesh;
}

}  // namespace cierzo::test
