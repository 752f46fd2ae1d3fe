// Three-component vectors of lanes: points, directions and RGB colours. With T = float it
// is an ordinary vector; with T = xsimd::batch it is the SoA view of K vectors.
#pragma once

#include "lanes.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template <class T>
struct Vec3 {
    T x, y, z;

    Vec3() = default;
    constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
    explicit constexpr Vec3(T v) : x(v), y(v), z(v) {}
    // Broadcast a scalar vector into every lane.
    template <class U, class = std::enable_if_t<!std::is_same_v<U, T>>>
    explicit Vec3(const Vec3<U>& v) : x(T(v.x)), y(T(v.y)), z(T(v.z)) {}

    Vec3& operator+=(const Vec3& o) {
        x += o.x;
        y += o.y;
        z += o.z;
        return *this;
    }
    Vec3& operator-=(const Vec3& o) {
        x -= o.x;
        y -= o.y;
        z -= o.z;
        return *this;
    }
    Vec3& operator*=(const Vec3& o) {
        x *= o.x;
        y *= o.y;
        z *= o.z;
        return *this;
    }
    Vec3& operator*=(const T& s) {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
    T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

using Vec3f = Vec3<float>;

template <class T>
Vec3<T> operator+(const Vec3<T>& a, const Vec3<T>& b) {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
Vec3<T> operator-(const Vec3<T>& a, const Vec3<T>& b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
Vec3<T> operator-(const Vec3<T>& a) {
    return {-a.x, -a.y, -a.z};
}
template <class T>
Vec3<T> operator*(const Vec3<T>& a, const Vec3<T>& b) {
    return {a.x * b.x, a.y * b.y, a.z * b.z};
}
template <class T>
Vec3<T> operator*(const Vec3<T>& a, const T& s) {
    return {a.x * s, a.y * s, a.z * s};
}
template <class T>
Vec3<T> operator*(const T& s, const Vec3<T>& a) {
    return {a.x * s, a.y * s, a.z * s};
}
template <class T>
Vec3<T> operator/(const Vec3<T>& a, const T& s) {
    const T r = T(1.0f) / s;
    return a * r;
}

template <class T>
T dot(const Vec3<T>& a, const Vec3<T>& b) {
    return fma(a.x, b.x, fma(a.y, b.y, a.z * b.z));
}
template <class T>
Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
T length(const Vec3<T>& a) {
    return sqrt(dot(a, a));
}
template <class T>
Vec3<T> normalize(const Vec3<T>& a) {
    return a * (T(1.0f) / length(a));
}
template <class T>
T max_component(const Vec3<T>& a) {
    return max(a.x, max(a.y, a.z));
}
template <class T>
Vec3<T> vmin(const Vec3<T>& a, const Vec3<T>& b) {
    return {min(a.x, b.x), min(a.y, b.y), min(a.z, b.z)};
}
template <class T>
Vec3<T> vmax(const Vec3<T>& a, const Vec3<T>& b) {
    return {max(a.x, b.x), max(a.y, b.y), max(a.z, b.z)};
}
template <class T, class M>
Vec3<T> select(const M& m, const Vec3<T>& a, const Vec3<T>& b) {
    return {select(m, a.x, b.x), select(m, a.y, b.y), select(m, a.z, b.z)};
}
// A fused a*s + b per component.
template <class T>
Vec3<T> fma(const Vec3<T>& a, const T& s, const Vec3<T>& b) {
    return {fma(a.x, s, b.x), fma(a.y, s, b.y), fma(a.z, s, b.z)};
}

// An orthonormal frame around a unit vector n (Duff et al., "Building an Orthonormal
// Basis, Revisited", JCGT 2017), branch-free so it vectorises.
template <class T>
void orthonormal_basis(const Vec3<T>& n, Vec3<T>& t, Vec3<T>& b) {
    const T sign = select(n.z >= T(0.0f), T(1.0f), T(-1.0f));
    const T a = T(-1.0f) / (sign + n.z);
    const T c = n.x * n.y * a;
    t = {T(1.0f) + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

// A ray: origin and direction (not necessarily unit length for all uses, but the
// integrators keep it unit length).
template <class T>
struct Ray {
    Vec3<T> o, d;
};

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
