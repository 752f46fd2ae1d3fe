// Spatial splits (SBVH, Stich et al. 2009) of the binary build (bvh_builder.h): a triangle's
// part in a slab clipped to a box, the cheapest plane binned over each axis, and a node's refs
// partitioned by it, a cut triangle becoming a ref on each side.
#include "accel/bvh_builder.h"

namespace cierzo {

Box Bvh::Builder::clipped(const Ref& r, int axis, float a, float b) const {
    Vec3f v[3];
    vertices(r, v);
    Box out = slab_box(v, axis, a, b);
    if (!(out.lo.x <= out.hi.x)) return Box{};
    const Vec3f pad(std::max(largest_abs(out.lo), largest_abs(out.hi)) * 0x1p-21f);
    out.lo = vmax(out.lo - pad, r.box.lo), out.hi = vmin(out.hi + pad, r.box.hi);
    float& lo = axis == 0 ? out.lo.x : (axis == 1 ? out.lo.y : out.lo.z);
    float& hi = axis == 0 ? out.hi.x : (axis == 1 ? out.hi.y : out.hi.z);
    lo = std::max(lo, a), hi = std::min(hi, b);
    if (!(out.lo.x <= out.hi.x && out.lo.y <= out.hi.y && out.lo.z <= out.hi.z)) return Box{};
    return out;
}

void Bvh::Builder::vertices(const Ref& r, Vec3f v[3]) const {
    const BvhTriangles& set = in.triangles[r.a];
    const uint32_t* tri = &set.indices[3 * size_t(r.b)];
    v[0] = set.positions[tri[0]], v[1] = set.positions[tri[1]], v[2] = set.positions[tri[2]];
}

bool Bvh::Builder::edge_crossing(const Vec3f v[3], int i, int axis, float plane, Vec3f& x) {
    const Vec3f& p = v[i];
    const Vec3f& q = v[i == 2 ? 0 : i + 1];
    const float pa = component(p, axis), qa = component(q, axis);
    if (!((pa < plane && qa > plane) || (pa > plane && qa < plane))) return false;
    x = p + (q - p) * ((plane - pa) / (qa - pa));
    (axis == 0 ? x.x : (axis == 1 ? x.y : x.z)) = plane;
    return true;
}

Box Bvh::Builder::slab_box(const Vec3f v[3], int axis, float a, float b) {
    Box out;
    for (int i = 0; i < 3; ++i) {
        const float pa = component(v[i], axis);
        if (pa >= a && pa <= b) out.grow(v[i]);
        Vec3f x;
        for (const float plane : {a, b})
            if (edge_crossing(v, i, axis, plane, x)) out.grow(x);
    }
    return out;
}

Bvh::Builder::SpatialSplit Bvh::Builder::find_spatial_split(uint32_t begin, uint32_t end,
                                                            const Box& bounds) const {
    SpatialSplit best[3];
    auto axis_split = [&](int axis) { best[axis] = find_spatial_split(begin, end, bounds, axis); };
    if (end - begin > kParallelBelow)  // (the axes in parallel where the tree is not yet)
        oneapi::tbb::parallel_invoke([&] { axis_split(0); }, [&] { axis_split(1); },
                                     [&] { axis_split(2); });
    else
        for (int axis = 0; axis < 3; ++axis) axis_split(axis);
    const int first = best[1].cost < best[0].cost ? 1 : 0;
    return best[2].cost < best[first].cost ? best[2] : best[first];
}

Bvh::Builder::SpatialSplit Bvh::Builder::find_spatial_split(uint32_t begin, uint32_t end,
                                                            const Box& bounds, int axis) const {
    SpatialSplit best, s;
    s.axis = axis, s.lo = component(bounds.lo, axis);
    const float extent = component(bounds.hi, axis) - s.lo;
    if (!(extent > 0.0f) || !std::isfinite(extent)) return best;
    s.scale = kSpatialBins / extent, s.width = extent / kSpatialBins;
    Box slabs[kSpatialBins];
    uint32_t enter[kSpatialBins] = {}, leave[kSpatialBins] = {};
    for (uint32_t i = begin; i < end; ++i) {
        const Ref& r = refs[order[i]];
        const int b0 = s.slab(component(r.box.lo, axis));
        const int b1 = s.slab(component(r.box.hi, axis));
        ++enter[b0], ++leave[b1];
        if (b0 == b1) {
            slabs[b0].grow(r.box);
            continue;
        }
        // (the SAH's estimate, each part's box unpadded, within the ref's: a slab's part
        // is its vertices and the crossings of its two planes, each plane's crossings
        // found once for the slabs on both sides)
        Vec3f v[3];
        vertices(r, v);
        Box parts[kSpatialBins];
        for (const Vec3f& p : v) parts[std::clamp(s.slab(component(p, axis)), b0, b1)].grow(p);
        for (int k = b0 + 1; k <= b1; ++k) {
            const float plane = s.lo + float(k) * s.width;
            Vec3f x;
            for (int i = 0; i < 3; ++i)
                if (edge_crossing(v, i, axis, plane, x)) parts[k - 1].grow(x), parts[k].grow(x);
        }
        for (int b = b0; b <= b1; ++b) {
            Box& part = parts[b];
            part.lo = vmax(part.lo, r.box.lo), part.hi = vmin(part.hi, r.box.hi);
            if (part.lo.x <= part.hi.x && part.lo.y <= part.hi.y && part.lo.z <= part.hi.z)
                slabs[b].grow(part);
        }
    }
    float right_area[kSpatialBins];
    uint32_t right_count[kSpatialBins];
    Box right;
    uint32_t count = 0;
    for (int b = kSpatialBins - 1; b > 0; --b) {
        right.grow(slabs[b]);
        count += leave[b];
        right_area[b] = right.half_area(), right_count[b] = count;
    }
    Box left;
    count = 0;
    for (int b = 1; b < kSpatialBins; ++b) {
        left.grow(slabs[b - 1]);
        count += enter[b - 1];
        if (count == 0 || right_count[b] == 0) continue;
        const float c = float(count) * left.half_area() + float(right_count[b]) * right_area[b];
        if (c < best.cost) {
            best = s;
            best.cost = c, best.plane = b, best.left = count, best.right = right_count[b];
        }
    }
    return best;
}

uint32_t Bvh::Builder::spatial_partition(uint32_t begin, uint32_t end, uint32_t ext_end,
                                         const SpatialSplit& sp, Extent& a, Extent& b, uint32_t& nl,
                                         uint32_t& nr) {
    std::vector<uint32_t> left, right;
    left.reserve(sp.left), right.reserve(sp.right);
    const float plane = sp.position();
    auto set_box = [](Ref& r, const Box& box) {
        r.box = box;
        r.centroid = (box.lo + box.hi) * 0.5f;
    };
    for (uint32_t i = begin; i < end; ++i) {
        const uint32_t id = order[i];
        Ref& r = refs[id];
        const int b0 = sp.slab(component(r.box.lo, sp.axis));
        const int b1 = sp.slab(component(r.box.hi, sp.axis));
        if (b1 < sp.plane || b0 >= sp.plane) {
            (b1 < sp.plane ? left : right).push_back(id);
            (b1 < sp.plane ? a : b).add(r);
            continue;
        }
        const Box l = clipped(r, sp.axis, -kInf, plane), h = clipped(r, sp.axis, plane, kInf);
        const bool has_l = l.lo.x <= l.hi.x, has_h = h.lo.x <= h.hi.x;
        if (has_l && has_h) {
            const uint32_t copy = ref_count.fetch_add(1, std::memory_order_relaxed);
            refs[copy] = r;
            set_box(r, l), set_box(refs[copy], h);
            left.push_back(id), right.push_back(copy);
            a.add(r), b.add(refs[copy]);
        } else if (has_h) {
            set_box(r, h);
            right.push_back(id), b.add(r);
        } else {
            if (has_l) set_box(r, l);
            left.push_back(id), a.add(r);
        }
    }
    nl = uint32_t(left.size()), nr = uint32_t(right.size());
    const uint32_t free = ext_end - begin - nl - nr;
    const uint32_t second = begin + nl + uint32_t(uint64_t(free) * nl / (nl + nr));
    std::copy(left.begin(), left.end(), order.data() + begin);
    std::copy(right.begin(), right.end(), order.data() + second);
    return second;
}

}  // namespace cierzo
