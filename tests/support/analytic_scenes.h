// Scenes with known answers (or every lobe kind) that several integrator tests render.
#pragma once

#include <cmath>

#include "support/render_variants.h"

namespace cierzo::test {

// A point light of intensity 1 at the centre of a closed diffuse sphere (R = 2, ρ = 0.5),
// the camera inside.
inline const char* kRoom = R"({"render": {"width": 16, "height": 16, "seed": 5},
    "camera": {"position": [0, 0, -1.2], "forward": [0, 0, -1], "left": [-2, 0, 0],
               "up": [0, 2, 0]},
    "materials": {"wall": {"kd": [0.5, 0.5, 0.5]}},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 2, "material": "wall"}],
    "lights": [{"position": [0, 0, 0], "intensity": [1, 1, 1]}]})";
inline constexpr double kRoomL = 0.5 / (M_PI * 4.0 * 0.5);  // 0.0796

// A diffuse ball (0.8) inside an emitting sphere (Le 1): every point of the ball sees only
// the emitter, so each pixel is 0.8 (the camera sees only the ball).
inline const char* kBall = R"({"render": {"width": 12, "height": 12, "seed": 9},
    "camera": {"position": [0, 0, -2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 20},
    "materials": {"ball": {"kd": [0.8, 0.8, 0.8]}, "L": {"emission": [1, 1, 1]}},
    "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 3, "material": "L"},
                {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "ball"}]})";

// A box of every lobe kind: diffuse and glossy walls, a mirror sphere, a glass sphere, lit by
// an emitting sphere, an emitting square of two triangles and a point light.
inline const char* kLobes = R"({"render": {"width": 20, "height": 16, "seed": 11},
    "camera": {"position": [0, 0, -3.2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 50},
    "materials": {"white": {"kd": [0.7, 0.7, 0.7]}, "red": {"kd": [0.7, 0.15, 0.1]},
                  "gloss": {"kd": [0.2, 0.4, 0.6], "ks": [0.3, 0.3, 0.3], "shininess": 20},
                  "mirror": {"kr": [0.9, 0.9, 0.9]},
                  "glass": {"kt": [0.95, 0.95, 0.95], "ior": 1.5},
                  "L": {"emission": [6, 5, 4]}, "Q": {"emission": [3, 3, 5]}},
    "objects": [
      {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "red"},
      {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "gloss"},
      {"type": "plane", "normal": [0, 0, -1], "distance": 1, "material": "white"},
      {"type": "plane", "normal": [0, 0, 1], "distance": 3.5, "material": "white"},
      {"type": "sphere", "center": [0.45, -0.6, 0.2], "radius": 0.35, "material": "mirror"},
      {"type": "sphere", "center": [-0.4, -0.6, -0.3], "radius": 0.35, "material": "glass"},
      {"type": "sphere", "center": [-0.5, 0.6, 0.3], "radius": 0.15, "material": "L"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, -0.2], [0.6, 0.99, 0.2]],
       "material": "Q"},
      {"type": "triangle", "vertices": [[0.2, 0.99, -0.2], [0.6, 0.99, 0.2], [0.2, 0.99, 0.2]],
       "material": "Q"}],
    "lights": [{"position": [-0.3, 0.2, -0.5], "intensity": [0.3, 0.3, 0.2]}]})";

// Every pixel's mean of a render of a scene whose pixels share one answer: the image mean
// within 3σ of `expected`, and σ below `sigma_bound` of it.
inline void expect_answer(const RenderResult& r, double expected, double sigma_bound) {
    for (int c = 0; c < 3; ++c) {
        const ImageMean m = image_mean(r.film, c);
        EXPECT_NEAR(m.mean, expected, 3.0 * m.sigma);
        EXPECT_LT(m.sigma, sigma_bound * expected);
    }
}

}  // namespace cierzo::test
