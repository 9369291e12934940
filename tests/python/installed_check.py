"""Run by test_install.py with a virtual environment's python: the aacbvh
package installed there (not the checkout's file) loads the library named by
$AACBVH_LIBRARY, builds a BVH and answers rays.

    VENV/bin/python tests/python/installed_check.py VENV
"""
import array
import os
import sys


def check(condition, what):
    if not condition:
        sys.exit("installed_check FAILED: " + what)


def main():
    venv = os.path.realpath(sys.argv[1])
    import aacbvh
    where = os.path.realpath(aacbvh.__file__)
    check(where.startswith(venv + os.sep), "aacbvh was imported from %s, not from %s" % (where, venv))
    from importlib.metadata import version
    check(version("aacbvh") == aacbvh.__version__,
          "pip installed version %s, the module says %s" % (version("aacbvh"), aacbvh.__version__))

    # The unit square as two indexed triangles, and one ray onto each half plus one beside it.
    vertices = array.array("f", [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0])
    indices = array.array("I", [0, 1, 2, 0, 2, 3])
    rays = [aacbvh.Ray((0.75, 0.25, 1.0), (0, 0, -1)), aacbvh.Ray((0.25, 0.75, 2.0), (0, 0, -1)),
            aacbvh.Ray((2.0, 2.0, 1.0), (0, 0, -1))]
    with aacbvh.Context(threads=1) as ctx, aacbvh.Bvh(ctx) as bvh:
        bvh.set_param(aacbvh.PARAM_BUILDER, aacbvh.BUILDER_AAC_FAST)
        bvh.set_triangles(vertices, indices)
        bvh.build()
        got = [(hit.prim_id, hit.t) for hit in bvh.intersect(rays)]
        check(got == [(0, 1.0), (1, 2.0), (aacbvh.INVALID_ID, float("inf"))], "hits %s" % (got,))
        try:
            import numpy
        except ImportError:
            numpy = None
        if numpy is not None:  # with --system-site-packages the system's numpy is seen
            hits = bvh.intersect(aacbvh.make_rays([r.org for r in rays], [0, 0, -1]))
            check(hits["prim_id"].tolist() == [0, 1, aacbvh.INVALID_ID], "numpy hits %s" % (hits,))
    print("installed aacbvh %s from %s (library %s): %d hits as expected%s"
          % (aacbvh.__version__, where, aacbvh.version(), len(got), ", numpy too" if numpy is not None else ""))


if __name__ == "__main__":
    main()
