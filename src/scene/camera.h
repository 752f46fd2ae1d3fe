// The report's pinhole camera: an origin and an image-plane frame (forward, left, up); a
// pixel's ray goes through a uniformly random point inside the pixel, and a point projects
// back onto the image.
#pragma once

#include "kernels/camera.h"

namespace cierzo {

struct Camera {
    Vec3f origin{0.0f};
    Vec3f forward{0.0f, 0.0f, 1.0f};  // from the origin to the image plane's centre
    Vec3f left{-1.0f, 0.0f, 0.0f};    // from the centre to the middle of the left edge
    Vec3f up{0.0f, 1.0f, 0.0f};       // from the centre to the middle of the top edge

    // Ray through image-plane point (sx, sy) in pixels, (0, 0) the top-left corner.
    template <class T>
    Ray<T> generate(const T& sx, const T& sy, float inv_width, float inv_height) const {
        return pinhole_ray(origin, forward, left, up, sx, sy, inv_width, inv_height);
    }
    // Where point p lands on a width × height image (kernels/camera.h), and the importance
    // of the direction towards it.
    template <class T>
    FilmPoint<T> project(const Vec3<T>& p, float width, float height) const {
        return pinhole_project(origin, forward, left, up, p, width, height);
    }
    Vec3f film_normal() const { return pinhole_film_normal(forward, left, up); }
    float film_area() const { return pinhole_film_area(forward, left, up); }
};

// How a look_at frame is oriented. Left-handed, the report's (and every scene of scenes/):
// with up = +y and looking along +z, +x is on the right of the image. Right-handed, the
// frame of OBJ, glTF and Blender scenes and their published cameras: the same camera sees
// +x on the left, so the image is the left-handed one mirrored left to right.
enum class Handedness { kLeft, kRight };

// The frame of a camera at `position` looking at `target` with vertical field of view
// `vfov_degrees` and the given aspect ratio (width / height).
Camera look_at_camera(const Vec3f& position, const Vec3f& target, const Vec3f& up_hint,
                      float vfov_degrees, float aspect, Handedness hand = Handedness::kLeft);

}  // namespace cierzo
