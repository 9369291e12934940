"""libaacbvh from Python through ctypes: a bumpy grid of triangles, built with
AAC-Fast, a few rays traced, the tree's figures printed, then one animation
step (vertices moved in place) and a refit. With numpy installed it also
traces a 64 x 64 grid of rays as one (n, 8) float32 array.

    AACBVH_LIBRARY=build/capi/libaacbvh.so.1 python3 examples/python/example.py
"""
import array
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import aacbvh  # noqa: E402


def grid(n):
    """(n+1)^2 vertices on a bumpy height field over [0, 1]^2, 2 n^2 triangles."""
    vertices = array.array("f")
    for j in range(n + 1):
        for i in range(n + 1):
            x, y = i / n, j / n
            vertices.extend((x, y, 0.05 * math.sin(8 * x) * math.cos(8 * y)))
    indices = array.array("I")
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            indices.extend((a, a + 1, a + n + 2, a, a + n + 2, a + n + 1))
    return vertices, indices


def main():
    vertices, indices = grid(64)
    print("libaacbvh", aacbvh.version())
    with aacbvh.Context(threads=2) as ctx, aacbvh.Bvh(ctx) as bvh:
        bvh.set_param(aacbvh.PARAM_BUILDER, aacbvh.BUILDER_AAC_FAST)
        bvh.set_triangles(vertices, indices)  # used in place: keep them alive
        bvh.build()
        s = bvh.stats()
        print("triangles %d, nodes %d, leaves %d, depth %d, SAH cost %.2f, %.1f bytes/triangle"
              % (s.primitive_count, s.node_count, s.leaf_count, s.max_depth, s.sah_cost,
                 s.memory_bytes / s.primitive_count))
        root = bvh.nodes(0, 1)[0]
        print("root box", tuple(round(c, 3) for c in root.lower), tuple(round(c, 3) for c in root.upper))

        probes = [aacbvh.Ray((0.3, 0.6, 1.0), (0.0, 0.0, -1.0)),
                  aacbvh.Ray((2.0, 2.0, 1.0), (0.0, 0.0, -1.0))]
        for ray, hit in zip(probes, bvh.intersect(probes)):
            org = tuple(round(c, 3) for c in ray.org)
            if hit.hit():
                print("ray from %s hits triangle %d at t = %.4f" % (org, hit.prim_id, hit.t))
            else:
                print("ray from %s misses" % (org,))

        try:
            import numpy
        except ImportError:
            numpy = None
        if numpy is not None:
            # Rays as one numpy array, answers as one structured array (no
            # Python object per ray): a grid looking down on the mesh.
            xy = (numpy.stack(numpy.meshgrid(numpy.arange(64), numpy.arange(64)), axis=-1).reshape(-1, 2) + 0.5) / 64
            rays = aacbvh.make_rays(numpy.column_stack([xy, numpy.ones(len(xy))]), [0.0, 0.0, -1.0])
            hits = bvh.intersect(rays)  # fields t, u, v, prim_id
            hit = hits["prim_id"] != aacbvh.INVALID_ID
            print("numpy: %d rays, %d hit, t from %.4f to %.4f"
                  % (len(rays), hit.sum(), hits["t"][hit].min(), hits["t"][hit].max()))

        # One animation step: lift every vertex in place, then refit.
        for k in range(2, len(vertices), 3):
            vertices[k] += 0.25
        bvh.refit()
        s = bvh.stats()
        print("after refit: SAH cost %.2f (built %.2f), hit t = %.4f"
              % (s.sah_cost, s.built_sah_cost, bvh.intersect(probes[:1])[0].t))


if __name__ == "__main__":
    main()
