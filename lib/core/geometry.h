// A non-owning view of the caller's triangles or boxes (never copied).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/box.h"

namespace aacbvh {

enum class GeometryKind { None, Triangles, Boxes };

struct Geometry {
    GeometryKind kind = GeometryKind::None;
    const float *vertices = nullptr;  ///< triangles: vertex k at byte k * vertex_stride
    size_t vertex_count = 0;
    size_t vertex_stride = 0;         ///< bytes
    const uint32_t *indices = nullptr; ///< 3 per triangle; NULL = 3i, 3i+1, 3i+2
    const float *boxes = nullptr;     ///< boxes: min xyz, max xyz at byte i * box_stride
    size_t box_stride = 0;            ///< bytes
    size_t primitive_count = 0;

    const float *vertex(size_t k) const {
        return reinterpret_cast<const float *>(reinterpret_cast<const char *>(vertices) + k * vertex_stride);
    }
    /// Vertex indices of triangle i (unchecked).
    void triangle_indices(size_t i, uint32_t out[3]) const {
        if (indices) {
            out[0] = indices[3 * i]; out[1] = indices[3 * i + 1]; out[2] = indices[3 * i + 2];
        } else {
            out[0] = uint32_t(3 * i); out[1] = uint32_t(3 * i + 1); out[2] = uint32_t(3 * i + 2);
        }
    }
    /// Asks the cache for triangle i's indices, then (once they are likely
    /// there) for its vertices: for passes that gather triangles out of order.
    void prefetch_indices(size_t i) const {
        if (indices) __builtin_prefetch(indices + 3 * i);
    }
    void prefetch_vertices(size_t i) const {
        uint32_t idx[3];
        triangle_indices(i, idx);
        __builtin_prefetch(vertex(idx[0]));
        __builtin_prefetch(vertex(idx[1]));
        __builtin_prefetch(vertex(idx[2]));
    }
    /// The three vertices of triangle i (indices assumed valid).
    void triangle(size_t i, const float *v[3]) const {
        uint32_t idx[3];
        triangle_indices(i, idx);
        v[0] = vertex(idx[0]); v[1] = vertex(idx[1]); v[2] = vertex(idx[2]);
    }
    const float *box_ptr(size_t i) const {
        return reinterpret_cast<const float *>(reinterpret_cast<const char *>(boxes) + i * box_stride);
    }
    /// Bounding box of primitive i (indices assumed valid).
    Box primitive_box(size_t i) const {
        Box b;
        if (kind == GeometryKind::Boxes) {
            std::memcpy(&b, box_ptr(i), sizeof b);
        } else {
            const float *v[3];
            triangle(i, v);
            b = Box::empty();
            b.extend(v[0]); b.extend(v[1]); b.extend(v[2]);
        }
        return b;
    }
};

} // namespace aacbvh
