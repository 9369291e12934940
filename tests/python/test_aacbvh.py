"""Tests of the ctypes binding examples/python/aacbvh.py against the built
library ($AACBVH_LIBRARY), the way a Python user calls it. Plain unittest;
numpy is used when installed and its tests are skipped otherwise.

    AACBVH_LIBRARY=build/capi/libaacbvh.so.1 python3 tests/python/test_aacbvh.py
"""
import array
import math
import os
import random
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "examples", "python"))
import aacbvh  # noqa: E402

try:
    import numpy
except ImportError:
    numpy = None


def random_triangles(count, seed):
    rng = random.Random(seed)
    vertices = array.array("f")
    for _ in range(count):
        cx, cy, cz = (rng.uniform(-1, 1) for _ in range(3))
        for _ in range(3):
            vertices.extend((cx + rng.uniform(-0.1, 0.1), cy + rng.uniform(-0.1, 0.1), cz + rng.uniform(-0.1, 0.1)))
    return vertices


def random_rays(count, seed):
    rng = random.Random(seed)
    rays = []
    for _ in range(count):
        org = [rng.uniform(-1.5, 1.5) for _ in range(3)]
        target = [rng.uniform(-0.8, 0.8) for _ in range(3)]
        rays.append(aacbvh.Ray(org, [t - o for t, o in zip(target, org)]))
    return rays


def brute_force(vertices, ray):
    """(t, prim) of the closest hit by Moller-Trumbore in double, or (inf, None)."""
    best_t, best_prim = math.inf, None
    o, d = list(ray.org), list(ray.dir)
    for prim in range(len(vertices) // 9):
        p = [vertices[9 * prim + k] for k in range(9)]
        e1 = [p[3 + k] - p[k] for k in range(3)]
        e2 = [p[6 + k] - p[k] for k in range(3)]
        h = [d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]]
        a = sum(e1[k] * h[k] for k in range(3))
        if abs(a) < 1e-12:
            continue
        s = [o[k] - p[k] for k in range(3)]
        u = sum(s[k] * h[k] for k in range(3)) / a
        if u < 0 or u > 1:
            continue
        q = [s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]]
        v = sum(d[k] * q[k] for k in range(3)) / a
        if v < 0 or u + v > 1:
            continue
        t = sum(e2[k] * q[k] for k in range(3)) / a
        if ray.tmin <= t <= ray.tmax and t < best_t:
            best_t, best_prim = t, prim
    return best_t, best_prim


class BindingTest(unittest.TestCase):
    def setUp(self):
        self.ctx = aacbvh.Context(threads=2)
        self.bvh = aacbvh.Bvh(self.ctx)

    def tearDown(self):
        self.bvh.close()
        self.ctx.close()

    def test_version(self):
        major, minor, patch = (int(x) for x in aacbvh.version().split("."))
        self.assertEqual(aacbvh.version_number(), major * 10000 + minor * 100 + patch)
        self.assertEqual(aacbvh.status_string(aacbvh.ERROR_CANCELLED), "AACBVH_ERROR_CANCELLED")
        self.assertEqual(self.ctx.thread_count, 2)

    def test_params(self):
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_BUILDER), aacbvh.BUILDER_AAC_HQ)
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_MAX_LEAF_SIZE), 4)
        self.bvh.set_param(aacbvh.PARAM_BUILDER, aacbvh.BUILDER_PLOC)
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_BUILDER), aacbvh.BUILDER_PLOC)
        self.bvh.set_param(aacbvh.PARAM_TRAVERSAL_COST, 2.5)
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_TRAVERSAL_COST), 2.5)
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.set_param(aacbvh.PARAM_MAX_LEAF_SIZE, 0)
        self.assertEqual(caught.exception.status, aacbvh.ERROR_INVALID_ARGUMENT)
        self.assertTrue(caught.exception.message)  # the library's explanation
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_MAX_LEAF_SIZE), 4)

    def test_constants_match_header(self):
        # Every enum value the binding names equals the C header's, and every
        # builder, parameter, layout and triangle storage the header has is named.
        import re
        header = os.path.join(HERE, "..", "..", "include", "aacbvh", "aacbvh.h")
        with open(header) as f:
            text = f.read()
        values = {m.group(1): int(m.group(2), 0)
                  for m in re.finditer(r"\bAACBVH_(\w+)\s*=\s*(0x[0-9A-Fa-f]+|-?\d+)", text)}
        named = [n for n in values if re.match(r"(BUILDER|PARAM|LAYOUT|TRIANGLES)_", n) and "MAX_ENUM" not in n]
        self.assertTrue(len(named) >= 20)
        for name in named:
            self.assertTrue(hasattr(aacbvh, name), "the binding lacks %s" % name)
        for name, value in values.items():
            if hasattr(aacbvh, name) and isinstance(getattr(aacbvh, name), int):
                self.assertEqual(getattr(aacbvh, name), value, name)

    def test_builders_from_the_library(self):
        # The library's builder table names every BUILDER_ constant of the binding.
        table = aacbvh.builders()
        self.assertEqual(table["aac-hq"], aacbvh.BUILDER_AAC_HQ)
        for name, value in table.items():
            self.assertEqual(getattr(aacbvh, "BUILDER_" + name.upper().replace("-", "_")), value, name)
        self.assertEqual(len(table), len([n for n in dir(aacbvh) if n.startswith("BUILDER_")]))

    def test_keep_build_memory(self):
        vertices = random_triangles(60000, 9)
        fresh = aacbvh.Bvh(self.ctx)
        try:
            fresh.set_triangles(vertices)
            fresh.build()
            self.bvh.set_param(aacbvh.PARAM_KEEP_BUILD_MEMORY, 1)
            self.assertEqual(self.bvh.get_param(aacbvh.PARAM_KEEP_BUILD_MEMORY), 1)
            self.bvh.set_triangles(vertices)
            for _ in range(3):  # the second and third reuse the kept memory
                self.bvh.build()
                self.assertEqual(bytes(self.bvh.nodes()), bytes(fresh.nodes()))
                self.assertEqual(bytes(self.bvh.primitive_indices()), bytes(fresh.primitive_indices()))
        finally:
            fresh.close()

    def test_misuse_raises(self):
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.intersect([aacbvh.Ray()])
        self.assertEqual(caught.exception.status, aacbvh.ERROR_INVALID_OPERATION)
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.refit()
        self.assertEqual(caught.exception.status, aacbvh.ERROR_INVALID_OPERATION)
        bad = array.array("f", [0, 0, 0, 1, 0, 0, float("nan"), 1, 0])
        self.bvh.set_triangles(bad)
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.build()
        self.assertEqual(caught.exception.status, aacbvh.ERROR_INVALID_GEOMETRY)

    def test_build_stats_nodes_intersect(self):
        vertices = random_triangles(300, seed=1)
        rays = random_rays(200, seed=2)
        for builder in (aacbvh.BUILDER_AAC_HQ, aacbvh.BUILDER_AAC_FAST, aacbvh.BUILDER_SWEEP_SAH,
                        aacbvh.BUILDER_PLOC):
            with self.subTest(builder=builder):
                self.bvh.set_param(aacbvh.PARAM_BUILDER, builder)
                self.bvh.set_triangles(vertices)
                self.bvh.build()
                s = self.bvh.stats()
                self.assertEqual(s.primitive_count, 300)
                self.assertEqual(s.node_count, 2 * s.leaf_count - 1)
                self.assertGreater(s.sah_cost, 0)
                self.assertAlmostEqual(s.sah_cost / s.built_sah_cost, 1.0, places=9)
                self.assertGreater(s.memory_bytes, s.node_count * 32)
                self.assertGreaterEqual(s.build_peak_bytes, s.memory_bytes - 4096)
                self.check_tree(vertices)
                hits = self.bvh.intersect(rays)
                occluded = self.bvh.occluded(rays)
                self.assertGreater(sum(h.hit() for h in hits), 20)  # not all misses
                for ray, hit, occ in zip(rays, hits, occluded):
                    t, prim = brute_force(vertices, ray)
                    self.assertEqual(hit.hit(), prim is not None)
                    self.assertEqual(occ, prim is not None)
                    if prim is not None:
                        self.assertAlmostEqual(hit.t, t, delta=1e-4 * max(1.0, t))

    def check_tree(self, vertices):
        nodes = self.bvh.nodes()
        prims = list(self.bvh.primitive_indices())
        self.assertEqual(sorted(prims), list(range(len(vertices) // 9)))
        for node in nodes:
            if node.is_leaf():
                for p in prims[node.first:node.first + node.count]:
                    for k in range(3):
                        for c in range(3):
                            x = vertices[9 * p + 3 * k + c]
                            self.assertTrue(node.lower[c] <= x <= node.upper[c])
            else:
                for child in (nodes[node.first], nodes[node.first + 1]):
                    for c in range(3):
                        self.assertLessEqual(node.lower[c], child.lower[c])
                        self.assertGreaterEqual(node.upper[c], child.upper[c])

    def test_indexed_and_readonly_buffers(self):
        # The unit square as two indexed triangles, from bytes (copied once).
        vertices = array.array("f", [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]).tobytes()
        indices = array.array("I", [0, 1, 2, 0, 2, 3]).tobytes()
        self.bvh.set_triangles(vertices, indices)
        self.bvh.build()
        hit = self.bvh.intersect([aacbvh.Ray((0.25, 0.75, 1.0), (0, 0, -1))])[0]
        self.assertEqual((hit.prim_id, hit.t), (1, 1.0))
        self.assertAlmostEqual(hit.u, 0.25)
        self.assertAlmostEqual(hit.v, 0.5)
        with self.assertRaises(ValueError):
            self.bvh.set_triangles(array.array("d", [0.0] * 9))

    def test_refit_sees_moved_vertices(self):
        vertices = random_triangles(200, seed=3)
        self.bvh.set_triangles(vertices)  # writable: used in place
        self.bvh.build()
        before = self.bvh.stats()
        ray = aacbvh.Ray((vertices[0], vertices[1], 5.0), (0, 0, -1))
        for i in range(len(vertices)):
            vertices[i] *= 2.0
        self.bvh.refit()
        after = self.bvh.stats()
        self.assertEqual(after.built_sah_cost, before.built_sah_cost)
        self.assertAlmostEqual(after.sah_cost, before.sah_cost, places=4)  # uniform scale keeps the cost
        root = self.bvh.nodes(0, 1)[0]
        self.assertEqual(root.lower[0], min(vertices[0::3]))
        self.assertEqual(root.upper[2], max(vertices[2::3]))
        hit = self.bvh.intersect([ray])[0]
        t, prim = brute_force(vertices, ray)
        self.assertEqual(hit.prim_id if hit.hit() else None, prim)

    def test_progress_and_cancel(self):
        vertices = random_triangles(2000, seed=4)
        self.bvh.set_triangles(vertices)
        self.bvh.build()
        nodes_before = bytes(self.bvh.nodes())
        fractions = []
        self.bvh.set_progress_callback(lambda f: fractions.append(f) or True)
        self.bvh.build()
        self.assertEqual(fractions[0], 0.0)
        self.assertEqual(fractions[-1], 1.0)
        self.assertEqual(fractions, sorted(fractions))
        self.bvh.set_progress_callback(lambda f: f < 0.5)
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.build()
        self.assertEqual(caught.exception.status, aacbvh.ERROR_CANCELLED)
        self.assertEqual(bytes(self.bvh.nodes()), nodes_before)  # the old tree is kept

        def boom(fraction):
            raise RuntimeError("an exception cancels the build")
        self.bvh.set_progress_callback(boom)
        with self.assertRaises(aacbvh.AacbvhError) as caught:
            self.bvh.build()
        self.assertEqual(caught.exception.status, aacbvh.ERROR_CANCELLED)
        self.bvh.set_progress_callback(None)
        self.bvh.build()

    def test_boxes(self):
        boxes = array.array("f", [0, 0, 0, 1, 1, 1, 2, 0, 0, 3, 1, 1])
        self.bvh.set_boxes(boxes)
        self.bvh.build()
        hits = self.bvh.intersect([aacbvh.Ray((2.5, 0.5, -1), (0, 0, 1)), aacbvh.Ray((1.5, 0.5, -1), (0, 0, 1))])
        self.assertEqual(hits[0].prim_id, 1)
        self.assertAlmostEqual(hits[0].t, 1.0)
        self.assertFalse(hits[1].hit())

    def test_empty_scene(self):
        self.bvh.set_triangles(array.array("f"))
        self.bvh.build()
        self.assertEqual(self.bvh.stats().node_count, 0)
        self.assertFalse(self.bvh.intersect([aacbvh.Ray()])[0].hit())

    @unittest.skipIf(numpy is None, "numpy is not installed")
    def test_numpy(self):
        rng = numpy.random.default_rng(5)
        vertices = rng.uniform(-1, 1, size=(400, 3)).astype(numpy.float32)
        indices = rng.integers(0, 400, size=(300, 3)).astype(numpy.uint32)
        self.bvh.set_triangles(vertices, indices)
        self.bvh.build()
        self.assertEqual(self.bvh.stats().primitive_count, 300)
        rays = numpy.zeros((4, 8), dtype=numpy.float32)
        rays[:, 2] = 5.0
        rays[:, 6] = -1.0
        rays[:, 7] = numpy.inf
        self.assertEqual(len(self.bvh.intersect(rays)), 4)
        vertices *= 3.0  # in place: refit sees it
        self.bvh.refit()
        self.assertGreater(self.bvh.nodes(0, 1)[0].upper[0], 1.5)


if __name__ == "__main__":
    unittest.main(verbosity=2)
