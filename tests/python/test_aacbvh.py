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
        with self.assertRaises(TypeError):  # float64 is not float32
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

    def test_optimize(self):
        vertices = random_triangles(3000, seed=8)
        self.bvh.set_triangles(vertices)
        with self.assertRaises(aacbvh.AacbvhError):
            self.bvh.optimize(1)  # no tree yet
        self.bvh.build()
        before = self.bvh.stats()
        self.bvh.optimize(2)
        after = self.bvh.stats()
        self.assertLess(after.sah_cost, before.sah_cost)
        self.assertEqual(after.built_sah_cost, after.sah_cost)
        self.assertEqual(after.primitive_count, before.primitive_count)
        rays = random_rays(40, seed=9)
        for ray, hit in zip(rays, self.bvh.intersect(rays)):
            t, prim = brute_force(vertices, ray)
            self.assertEqual(hit.prim_id if hit.hit() else None, prim)
        self.bvh.set_param(aacbvh.PARAM_OPTIMIZE_PASSES, 2)
        self.assertEqual(self.bvh.get_param(aacbvh.PARAM_OPTIMIZE_PASSES), 2)
        self.bvh.build()
        self.assertLess(self.bvh.stats().sah_cost, before.sah_cost)

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

    def test_version_follows_the_header(self):
        # The binding (and the package pip installs, whose version is read from
        # aacbvh.__version__) carries the version of the header it binds.
        import re
        with open(os.path.join(HERE, "..", "..", "include", "aacbvh", "aacbvh.h")) as f:
            parts = dict(re.findall(r"#define AACBVH_VERSION_(MAJOR|MINOR|PATCH) (\d+)", f.read()))
        self.assertEqual(aacbvh.__version__, "%s.%s.%s" % (parts["MAJOR"], parts["MINOR"], parts["PATCH"]))


UNIT_SQUARE = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]  # 4 vertices; triangles (0 1 2) (0 2 3)
DOWN = dict(dir=(0, 0, -1))


class ValidationTest(unittest.TestCase):
    """Arguments are checked before they reach the library: TypeError for the
    wrong element type, ValueError for the wrong shape, stride or size, each
    naming what is expected; never a ZeroDivisionError or a silent misread."""

    def setUp(self):
        self.ctx = aacbvh.Context(threads=2)
        self.bvh = aacbvh.Bvh(self.ctx)
        # A built tree that a refused call must leave alone.
        self.bvh.set_triangles(array.array("f", UNIT_SQUARE), array.array("I", [0, 1, 2, 0, 2, 3]))
        self.bvh.build()

    def tearDown(self):
        self.bvh.close()
        self.ctx.close()

    def assert_unchanged(self):
        hit = self.bvh.intersect([aacbvh.Ray((0.25, 0.75, 1.0), **DOWN)])[0]
        self.assertEqual((hit.prim_id, hit.t), (1, 1.0))
        self.assertEqual(self.bvh.stats().primitive_count, 2)

    def raises(self, exc, fn, *args, contains=(), **kwargs):
        with self.assertRaises(exc) as caught:
            fn(*args, **kwargs)
        for text in contains:
            self.assertIn(text, str(caught.exception))
        self.assert_unchanged()
        return str(caught.exception)

    def test_vertex_stride(self):
        vertices = array.array("f", UNIT_SQUARE)
        for stride in (0, 4, 8, 13, -12):
            with self.subTest(stride=stride):
                self.raises(ValueError, self.bvh.set_triangles, vertices, vertex_stride_bytes=stride,
                            contains=("vertex_stride_bytes", "multiple of 4 and at least 12", "got %d" % stride))
        self.raises(TypeError, self.bvh.set_triangles, vertices, vertex_stride_bytes=12.0,
                    contains=("vertex_stride_bytes must be an int",))
        for stride in (0, 20, 26):
            with self.subTest(box_stride=stride):
                self.raises(ValueError, self.bvh.set_boxes, array.array("f", [0] * 12), stride_bytes=stride,
                            contains=("stride_bytes", "at least 24"))

    def test_strided_buffer(self):
        # x, y, z, w per vertex at stride 16; the last vertex may lack its w.
        padded = array.array("f")
        for k in range(4):
            padded.extend(UNIT_SQUARE[3 * k:3 * k + 3] + [99.0])
        for data in (padded, padded[:-1]):
            self.bvh.set_triangles(data, [(0, 1, 2), (0, 2, 3)], vertex_stride_bytes=16)
            self.bvh.build()
            self.assert_unchanged()
        # 10 floats at stride 16: 2 whole vertices and 8 bytes of a third.
        self.raises(ValueError, self.bvh.set_triangles, padded[:10], [0, 1, 1], vertex_stride_bytes=16,
                    contains=("40 bytes", "16 bytes apart"))

    def test_element_types(self):
        self.raises(TypeError, self.bvh.set_triangles, array.array("d", UNIT_SQUARE),
                    contains=("vertices must be float32", "got array('d') of 12 items"))
        self.raises(TypeError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE), array.array("d", [0, 1, 2]),
                    contains=("indices must be uint32", "array('d')"))
        self.raises(TypeError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE), array.array("H", [0, 1, 2]),
                    contains=("indices must be uint32",))
        self.raises(TypeError, self.bvh.set_triangles, ["a", "b", "c"], contains=("vertices must be float32",))
        self.raises(TypeError, self.bvh.set_triangles, 12, contains=("got int",))
        self.raises(TypeError, self.bvh.set_boxes, array.array("d", [0] * 6), contains=("boxes must be float32",))
        self.raises(ValueError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE), [0, 1, -2],
                    contains=("uint32 range",))

    def test_sizes_and_layout(self):
        self.raises(ValueError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE[:10]),
                    contains=("vertices must be float32", "40 bytes", "12-byte elements"))
        # 4 vertices are not whole triangles without indices.
        self.raises(ValueError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE),
                    contains=("whole triangles", "got 4 vertices"))
        self.raises(ValueError, self.bvh.set_triangles, array.array("f", UNIT_SQUARE), array.array("I", [0, 1, 2, 3]),
                    contains=("indices must be uint32", "16 bytes"))
        self.raises(ValueError, self.bvh.set_triangles, bytes(14), contains=("14 bytes",))
        self.raises(ValueError, self.bvh.set_triangles, [(0, 0, 0), (1, 0)], contains=("an element has 2 numbers",))
        self.raises(ValueError, self.bvh.set_boxes, array.array("f", [0] * 7), contains=("boxes", "6"))
        strided = memoryview(array.array("f", UNIT_SQUARE * 2))[::2]
        self.raises(ValueError, self.bvh.set_triangles, strided, contains=("not C-contiguous",))
        self.raises(ValueError, self.bvh.set_triangles, memoryview(bytearray(40))[1:37],
                    contains=("not 4-byte aligned",))

    def test_rays(self):
        expected = "rays must be float32 with shape (n, 8) or a sequence of Ray"
        self.raises(TypeError, self.bvh.intersect, array.array("d", [0] * 8), contains=(expected, "array('d')"))
        self.raises(TypeError, self.bvh.intersect, [(0.2, 0.2, 1, 0, 0, 0, -1, 1e30)],
                    contains=(expected, "a list holding tuple"))
        self.raises(TypeError, self.bvh.occluded, 5, contains=(expected, "got int"))
        self.raises(ValueError, self.bvh.intersect, bytes(33), contains=(expected, "32 bytes"))
        self.raises(ValueError, self.bvh.intersect, array.array("f", [0] * 12), contains=(expected,))
        # A buffer of 8 float32 per ray answers as the Ray objects do.
        rays = [aacbvh.Ray((0.25, 0.75, 1.0), **DOWN), aacbvh.Ray((2, 2, 1), **DOWN)]
        flat = array.array("f")
        for ray in rays:
            flat.extend(list(ray.org) + [ray.tmin] + list(ray.dir) + [ray.tmax])
        for data in (flat, flat.tobytes(), (aacbvh.Ray * 2)(*rays)):
            hits = self.bvh.intersect(data)
            self.assertEqual([(h.prim_id, h.t) for h in hits], [(1, 1.0), (aacbvh.INVALID_ID, math.inf)])
            self.assertEqual(self.bvh.occluded(data), [True, False])
        self.assertEqual(len(self.bvh.intersect([])), 0)
        self.assertEqual(self.bvh.occluded([]), [])

    def test_sequences_are_copied(self):
        # Nested Python sequences are accepted (and copied: later changes to
        # the list do not reach the library).
        vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
        self.bvh.set_triangles(vertices, [[0, 1, 2], [0, 2, 3]])
        vertices[0][2] = 100.0
        self.bvh.build()
        self.assertEqual(self.bvh.nodes(0, 1)[0].upper[2], 0.0)
        self.assert_unchanged()
        self.bvh.set_boxes([(0, 0, 0, 1, 1, 1)])
        self.bvh.build()
        self.assertEqual(self.bvh.intersect([aacbvh.Ray((0.5, 0.5, 3), **DOWN)])[0].t, 2.0)


class LoadErrorTest(unittest.TestCase):
    """Where the library comes from, and what a user reads when it cannot load."""

    def run_python(self, code, env_library, cwd=None, module_dir=None):
        import subprocess
        env = dict(os.environ)
        env.pop("AACBVH_LIBRARY", None)
        env.pop("LD_LIBRARY_PATH", None)
        if env_library is not None:
            env["AACBVH_LIBRARY"] = env_library
        env["PYTHONPATH"] = module_dir or os.path.join(HERE, "..", "..", "examples", "python")
        return subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd or HERE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=60)

    def test_missing_library_says_how_to_fix_it(self):
        bogus = "/nonexistent/aacbvh-test/libaacbvh.so.1"
        done = self.run_python("import aacbvh\n"
                               "try:\n"
                               "    aacbvh.Context()\n"
                               "except aacbvh.LibraryLoadError as e:\n"
                               "    print(isinstance(e, OSError), e.tried[0][0])\n"
                               "    print(e)\n", bogus)
        self.assertEqual(done.returncode, 0, done.stderr)
        first, message = done.stdout.split("\n", 1)
        self.assertEqual(first, "True " + bogus)
        for text in ("AACBVH_LIBRARY", bogus, "No such file", "cmake --install build", "ldconfig",
                     "AACBVH_LIBRARY=/path/to/libaacbvh.so.1"):
            self.assertIn(text, message)
        # Uncaught, the same words reach the user (import itself succeeds).
        done = self.run_python("import aacbvh; print(aacbvh.version())", bogus)
        self.assertNotEqual(done.returncode, 0)
        self.assertIn("aacbvh.LibraryLoadError: cannot load libaacbvh; tried " + bogus, done.stderr)
        self.assertIn("cmake --install build, then ldconfig", done.stderr)

    def test_wrong_library(self):
        # A library that loads but is not libaacbvh (libc) is named as such.
        import ctypes.util
        libc = ctypes.util.find_library("c")
        if libc is None:
            self.skipTest("no libc found by name")
        done = self.run_python("import aacbvh\n"
                               "try:\n"
                               "    aacbvh.library()\n"
                               "except OSError as e:\n"
                               "    print(type(e).__name__, e)\n", libc)
        self.assertIn("LibraryLoadError %s (from $AACBVH_LIBRARY) lacks aacbvh_version_number()" % libc, done.stdout)

    def test_library_next_to_the_module(self):
        # With no $AACBVH_LIBRARY, a libaacbvh.so.1 beside aacbvh.py is used
        # (a packager may put it there); the built library stands in for it.
        import shutil
        import tempfile
        built = os.environ.get("AACBVH_LIBRARY")
        if not built:
            self.skipTest("AACBVH_LIBRARY does not name the built library")
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copy(os.path.join(HERE, "..", "..", "examples", "python", "aacbvh.py"), tmp)
            os.symlink(os.path.abspath(built), os.path.join(tmp, aacbvh.LIBRARY_NAME))
            done = self.run_python("import aacbvh; print(aacbvh.library_candidates()[0][1]); "
                                   "print(aacbvh.library()._name); print(aacbvh.version())",
                                   None, cwd=tmp, module_dir=tmp)
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertEqual(done.stdout.split("\n")[:3],
                             ["next to aacbvh.py", os.path.join(os.path.realpath(tmp), aacbvh.LIBRARY_NAME),
                              aacbvh.version()])


@unittest.skipIf(numpy is None, "numpy is not installed")
class NumpyTest(unittest.TestCase):
    """numpy arrays in, numpy arrays out, checked and never copied."""

    def setUp(self):
        self.ctx = aacbvh.Context(threads=2)
        self.bvh = aacbvh.Bvh(self.ctx)
        rng = numpy.random.default_rng(5)
        centers = rng.uniform(-1, 1, size=(300, 1, 3))
        self.soup = (centers + rng.uniform(-0.15, 0.15, size=(300, 3, 3))).astype(numpy.float32)  # (t, 3, 3)
        self.vertices = self.soup.reshape(-1, 3)  # a view: (900, 3)
        self.indices = numpy.arange(900, dtype=numpy.uint32).reshape(300, 3)[rng.permutation(300)]
        org = rng.uniform(-1.5, 1.5, size=(256, 3))
        self.rays = aacbvh.make_rays(org, rng.uniform(-0.8, 0.8, size=(256, 3)) - org)

    def tearDown(self):
        self.bvh.close()
        self.ctx.close()

    def ray_objects(self, rays):
        return [aacbvh.Ray(r[0:3], r[4:7], r[3], r[7]) for r in rays]

    def reference(self, rays):
        """(t, u, v, prim_id) and occluded per ray, through Ray objects and ctypes."""
        objects = self.ray_objects(rays)
        hits = self.bvh.intersect(objects)
        return [(h.t, h.u, h.v, h.prim_id) for h in hits], self.bvh.occluded(objects)

    def check_answers(self, rays, min_hits=20):
        hits, occluded = self.bvh.intersect(rays), self.bvh.occluded(rays)
        self.assertIsInstance(hits, numpy.ndarray)
        self.assertEqual(hits.dtype, aacbvh.HIT_DTYPE)
        self.assertEqual(hits.dtype.names, ("t", "u", "v", "prim_id"))
        self.assertEqual(hits.shape, (len(rays),))
        self.assertEqual(occluded.dtype, numpy.bool_)
        ref_hits, ref_occluded = self.reference(rays)
        self.assertEqual(hits.tolist(), ref_hits)
        self.assertEqual(occluded.tolist(), ref_occluded)
        hit_mask = hits["prim_id"] != aacbvh.INVALID_ID
        self.assertGreater(int(hit_mask.sum()), min_hits)
        self.assertLess(int(hit_mask.sum()), len(rays))  # some misses too
        self.assertTrue(numpy.array_equal(hit_mask, occluded))
        return hits

    def test_numpy_in_numpy_out(self):
        self.bvh.set_triangles(self.vertices, self.indices)
        self.bvh.build()
        self.assertEqual(self.bvh.stats().primitive_count, 300)
        hits = self.check_answers(self.rays)
        # The hits agree with a brute force over the triangles in index order.
        flat = self.vertices[self.indices].reshape(-1).tolist()
        for ray, hit in zip(self.ray_objects(self.rays[:64]), hits[:64]):
            t, prim = brute_force(flat, ray)
            self.assertEqual(hit["prim_id"], aacbvh.INVALID_ID if prim is None else prim)
            if prim is not None:
                self.assertAlmostEqual(float(hit["t"]), t, delta=1e-4 * max(1.0, t))
        # RAY_DTYPE records are the same rays.
        structured = self.rays.view(aacbvh.RAY_DTYPE).reshape(-1)
        self.assertEqual(self.bvh.intersect(structured).tolist(), hits.tolist())
        self.assertEqual(structured["dir"].tolist(), self.rays[:, 4:7].tolist())
        # The case: 4 float32 rays straight down onto the scene, 4 answers.
        four = aacbvh.make_rays(self.soup[:4].mean(axis=1) + [0, 0, 5], [0, 0, -1])
        self.assertEqual(len(self.bvh.intersect(four)), 4)
        self.assertTrue(self.bvh.occluded(four).all())
        empty = self.bvh.intersect(numpy.empty((0, 8), numpy.float32))
        self.assertEqual((empty.shape, empty.dtype), ((0,), aacbvh.HIT_DTYPE))
        self.assertEqual(self.bvh.occluded(numpy.empty((0, 8), numpy.float32)).shape, (0,))

    def test_layouts_answer_alike(self):
        # Triangle soup as (t, 3, 3), as (3 t, 3), flat, and indexed: one tree's answers.
        self.bvh.set_triangles(self.soup)
        self.bvh.build()
        expected = self.check_answers(self.rays).tolist()
        for vertices in (self.vertices, self.soup.reshape(-1)):
            self.bvh.set_triangles(vertices)
            self.bvh.build()
            self.assertEqual(self.bvh.intersect(self.rays).tolist(), expected)
        # Boxes as (n, 6) and (n, 2, 3).
        boxes = numpy.concatenate([self.soup.min(axis=1), self.soup.max(axis=1)], axis=1)
        self.bvh.set_boxes(boxes)
        self.bvh.build()
        box_hits = self.check_answers(self.rays).tolist()
        self.bvh.set_boxes(boxes.reshape(-1, 2, 3))
        self.bvh.build()
        self.assertEqual(self.bvh.intersect(self.rays).tolist(), box_hits)

    def test_wrong_dtype_is_a_type_error(self):
        with self.assertRaises(TypeError) as caught:
            self.bvh.intersect(self.rays[:4].astype(numpy.float64))
        self.assertEqual(str(caught.exception),
                         "rays must be float32 with shape (n, 8) or a sequence of Ray; got float64 (4, 8)")
        with self.assertRaises(TypeError):
            self.bvh.occluded(self.rays.astype(numpy.float16))
        cases = [
            (self.bvh.set_triangles, (self.vertices.astype(numpy.float64),), "vertices must be float32", "float64 (900, 3)"),
            (self.bvh.set_triangles, (self.vertices.astype(">f4"),), "vertices must be float32", ">f4"),
            (self.bvh.set_triangles, (self.vertices, self.indices.astype(numpy.int64)), "indices must be uint32", "int64 (300, 3)"),
            (self.bvh.set_triangles, (self.vertices, self.indices.astype(numpy.float32)), "indices must be uint32", "float32"),
            (self.bvh.set_boxes, (numpy.zeros((2, 6)),), "boxes must be float32", "float64 (2, 6)"),
        ]
        for fn, args, expected, got in cases:
            with self.subTest(expected=expected, got=got):
                with self.assertRaises(TypeError) as caught:
                    fn(*args)
                self.assertIn(expected, str(caught.exception))
                self.assertIn("got " + got, str(caught.exception))

    def test_wrong_shape_is_a_value_error(self):
        rays = self.rays
        for bad in (rays[:, :7], rays.reshape(-1), rays.reshape(-1, 16), rays.reshape(2, -1, 8)):
            with self.subTest(shape=bad.shape):
                with self.assertRaises(ValueError) as caught:
                    self.bvh.intersect(bad)
                self.assertEqual(str(caught.exception), "rays must be float32 with shape (n, 8) or a sequence of Ray; "
                                 "got float32 %s" % (bad.shape,))
        v, i = self.vertices, self.indices
        cases = [
            (self.bvh.set_triangles, (numpy.zeros((9, 4), numpy.float32),), "vertices", "(9, 4)"),
            (self.bvh.set_triangles, (numpy.zeros((3, 2, 3), numpy.float32),), "vertices", "(3, 2, 3)"),
            (self.bvh.set_triangles, (v.reshape(-1)[:10],), "vertices", "(10,)"),
            (self.bvh.set_triangles, (v[:4],), "whole triangles", "(4, 3)"),
            (self.bvh.set_triangles, (v, i.reshape(-1, 2)), "indices", "(450, 2)"),
            (self.bvh.set_triangles, (v, i.reshape(-1)[:7]), "indices", "(7,)"),
            (self.bvh.set_triangles, (v, i[:, :, None]), "indices", "(300, 3, 1)"),
            (self.bvh.set_boxes, (numpy.zeros((4, 5), numpy.float32),), "boxes", "(4, 5)"),
            (self.bvh.set_triangles, (numpy.float32(1.0),), "vertices", "()"),
        ]
        for fn, args, expected, got in cases:
            with self.subTest(expected=expected, got=got):
                with self.assertRaises(ValueError) as caught:
                    fn(*args)
                self.assertIn(expected, str(caught.exception))
                self.assertIn(got, str(caught.exception))

    def test_stride(self):
        with self.assertRaises(ValueError) as caught:
            self.bvh.set_triangles(self.vertices, vertex_stride_bytes=0)
        self.assertIn("vertex_stride_bytes must be a multiple of 4 and at least 12; got 0", str(caught.exception))
        with self.assertRaises(ValueError) as caught:  # (n, 3) rows are 12 bytes apart, not 16
            self.bvh.set_triangles(self.vertices, vertex_stride_bytes=16)
        self.assertIn("does not match the array's rows, 12 bytes apart", str(caught.exception))
        # A flat array with an explicit stride: x, y, z, w per vertex.
        xyzw = numpy.concatenate([self.vertices, numpy.full((900, 1), 7, numpy.float32)], axis=1)
        self.bvh.set_triangles(self.vertices)
        self.bvh.build()
        expected = self.bvh.intersect(self.rays).tolist()
        self.bvh.set_triangles(xyzw.reshape(-1), vertex_stride_bytes=16)
        self.bvh.build()
        self.assertEqual(self.bvh.intersect(self.rays).tolist(), expected)

    def test_non_contiguous(self):
        v, i = self.vertices, self.indices
        for fn, args in ((self.bvh.set_triangles, (v[:, ::-1],)),                   # reversed columns
                         (self.bvh.set_triangles, (numpy.asfortranarray(v),)),      # column-major
                         (self.bvh.set_triangles, (v.reshape(-1)[::2][:900],)),     # every other float
                         (self.bvh.set_triangles, (self.soup[::2],)),              # (t, 3, 3) strided
                         (self.bvh.set_triangles, (v, i[::2])),                     # strided indices
                         (self.bvh.set_triangles, (v, numpy.asfortranarray(i))),
                         (self.bvh.set_boxes, (numpy.zeros((8, 12), numpy.float32)[:, ::2],))):
            with self.subTest(shape=args[-1].shape, strides=args[-1].strides):
                with self.assertRaises(ValueError) as caught:
                    fn(*args)
                self.assertIn("contiguous", str(caught.exception).replace("packed", "contiguous"))
        # Unaligned float32 data is refused too.
        raw = numpy.zeros(4 * 9 + 1, numpy.uint8)[1:].view(numpy.float32)
        with self.assertRaises(ValueError) as caught:
            self.bvh.set_triangles(raw)
        self.assertIn("4-byte aligned", str(caught.exception))

    def test_strided_rows_used_in_place(self):
        # Positions inside an interleaved (n, 8) vertex array: rows 32 bytes
        # apart, passed as they are (vertex_stride_bytes = 32), never copied.
        interleaved = numpy.zeros((900, 8), numpy.float32)
        interleaved[:, :3] = self.vertices
        interleaved[:, 3:] = 42.0
        positions = interleaved[:, :3]
        self.assertFalse(positions.flags.c_contiguous)
        self.bvh.set_triangles(self.vertices, self.indices)
        self.bvh.build()
        expected = self.bvh.intersect(self.rays).tolist()
        self.bvh.set_triangles(positions, self.indices)
        self.bvh.build()
        self.assertEqual(self.bvh.intersect(self.rays).tolist(), expected)
        interleaved[:, 2] += 10.0  # lift everything in place
        self.bvh.refit()
        self.assertAlmostEqual(self.bvh.nodes(0, 1)[0].lower[2], float(self.vertices[:, 2].min()) + 10, places=4)
        with self.assertRaises(ValueError):  # the stride comes from the array
            self.bvh.set_triangles(positions, self.indices, vertex_stride_bytes=12)
        # Rays are read only during the call: a strided ray array is copied, with the same answers.
        wide = numpy.zeros((256, 16), numpy.float32)
        wide[:, :8] = self.rays
        self.assertEqual(self.bvh.intersect(wide[:, :8]).tolist(), self.bvh.intersect(self.rays).tolist())
        self.assertEqual(self.bvh.intersect(self.rays[::3]).tolist(),
                         self.bvh.intersect(numpy.ascontiguousarray(self.rays[::3])).tolist())

    def test_no_copy_refit_sees_moved_vertices(self):
        vertices = numpy.ascontiguousarray(self.vertices)
        indices = numpy.ascontiguousarray(self.indices).astype(numpy.int32)  # int32 is taken as uint32
        self.bvh.set_triangles(vertices, indices)
        self.bvh.build()
        target = self.soup[7].mean(axis=0)
        down = aacbvh.make_rays(target + [0, 0, 10], [0, 0, -1])
        before = self.bvh.intersect(down)[0]
        self.assertNotEqual(before["prim_id"], aacbvh.INVALID_ID)
        root_before = self.bvh.nodes(0, 1)[0]
        vertices[:, 2] += 2.5  # in place: the library reads this very memory
        self.bvh.refit()
        root = self.bvh.nodes(0, 1)[0]
        self.assertAlmostEqual(root.upper[2], root_before.upper[2] + 2.5, places=4)
        self.assertAlmostEqual(root.lower[0], root_before.lower[0], places=6)
        after = self.bvh.intersect(down)[0]
        self.assertEqual(after["prim_id"], before["prim_id"])
        self.assertAlmostEqual(float(after["t"]), float(before["t"]) - 2.5, places=4)
        # The Bvh holds the arrays: dropping ours leaves the geometry valid.
        del vertices, indices
        import gc
        gc.collect()
        self.bvh.refit()
        self.assertEqual(self.bvh.intersect(down)[0]["prim_id"], before["prim_id"])

    def test_make_rays(self):
        rays = aacbvh.make_rays([[1, 2, 3], [4, 5, 6]], [0, 0, -1], tmin=0.5, tmax=[7, 8])
        self.assertEqual((rays.dtype, rays.shape), (numpy.float32, (2, 8)))
        self.assertEqual(rays.tolist(), [[1, 2, 3, 0.5, 0, 0, -1, 7], [4, 5, 6, 0.5, 0, 0, -1, 8]])


def main():
    """All tests, or with --numpy only NumpyTest, or with --no-numpy all but it
    (ctest runs the two halves as python_binding and python_numpy, so that a
    missing numpy shows as a skipped test)."""
    args = sys.argv[1:]
    loader = unittest.TestLoader()
    classes = [BindingTest, ValidationTest, LoadErrorTest, NumpyTest]
    if args[:1] == ["--numpy"]:
        classes, args = [NumpyTest], args[1:]
    elif args[:1] == ["--no-numpy"]:
        classes, args = [c for c in classes if c is not NumpyTest], args[1:]
    if args:
        suite = loader.loadTestsFromNames(args, sys.modules[__name__])
    else:
        suite = unittest.TestSuite(loader.loadTestsFromTestCase(c) for c in classes)
    result = unittest.TextTestRunner(verbosity=2).run(suite)
    sys.exit(0 if result.wasSuccessful() else 1)


if __name__ == "__main__":
    main()
