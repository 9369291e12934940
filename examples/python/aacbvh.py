"""A small ctypes binding of libaacbvh (no compiled extension; numpy optional).

    import array, aacbvh
    vertices = array.array("f", [0, 0, 0,  1, 0, 0,  0, 1, 0])
    with aacbvh.Context() as ctx, aacbvh.Bvh(ctx) as bvh:
        bvh.set_param(aacbvh.PARAM_BUILDER, aacbvh.BUILDER_AAC_FAST)
        bvh.set_triangles(vertices)          # referenced, not copied
        bvh.build()
        hits = bvh.intersect([aacbvh.Ray((0.2, 0.2, 1), (0, 0, -1))])
        print(hits[0].prim_id, hits[0].t, bvh.stats().sah_cost)

The library is found through $AACBVH_LIBRARY (a path to libaacbvh.so.1),
else the system's library search (ctypes.util.find_library("aacbvh")).

Every failing call raises AacbvhError, which carries the status and the
library's message. Buffers follow the C API's lifetime rule: the library keeps
pointers into them, so the Bvh object keeps a reference to each buffer it was
given. A writable buffer (array.array, bytearray, a C-contiguous numpy array)
is used in place, so moving its vertices and calling refit() works; a
read-only one (bytes) is copied once. The header include/aacbvh/aacbvh.h is
the manual; the names here are its names without the aacbvh_ prefix.
"""

import ctypes
import ctypes.util
import os

# ---- status codes, builders, parameters, layouts (values pinned by the ABI) ----

OK = 0
ERROR_INVALID_ARGUMENT = 1
ERROR_INVALID_OPERATION = 2
ERROR_OUT_OF_MEMORY = 3
ERROR_INVALID_GEOMETRY = 4
ERROR_CANCELLED = 5
ERROR_INTERNAL = 6

BUILDER_AAC_HQ = 0
BUILDER_AAC_FAST = 1
BUILDER_AAC = 2
BUILDER_SWEEP_SAH = 3
BUILDER_BINNED_SAH = 4
BUILDER_LOCALLY_ORDERED = 5
BUILDER_PLOC = 6

PARAM_BUILDER = 0
PARAM_AAC_DELTA = 1
PARAM_MAX_LEAF_SIZE = 2
PARAM_AAC_C = 3
PARAM_AAC_ALPHA = 4
PARAM_TRAVERSAL_COST = 5
PARAM_INTERSECTION_COST = 6
PARAM_PLOC_RADIUS = 7
PARAM_SKIP_INVALID_PRIMITIVES = 8
PARAM_TRAVERSAL_LAYOUT = 9
PARAM_TRIANGLE_STORAGE = 10
PARAM_KEEP_BUILD_MEMORY = 11

LAYOUT_BINARY = 0
LAYOUT_WIDE4 = 1

TRIANGLES_REFERENCED = 0
TRIANGLES_COPIED = 1

INVALID_ID = 0xFFFFFFFF

#: Parameters read and written as floats; the others are integers.
FLOAT_PARAMS = frozenset((PARAM_AAC_C, PARAM_AAC_ALPHA, PARAM_TRAVERSAL_COST, PARAM_INTERSECTION_COST))


class AacbvhError(Exception):
    """A failed call: .status is the aacbvh_status value, .status_name its name."""

    def __init__(self, status, status_name, message):
        super().__init__("%s: %s" % (status_name, message) if message else status_name)
        self.status = status
        self.status_name = status_name
        self.message = message


# ---- structs (layouts frozen by the ABI; see the header) ----

class Stats(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("max_depth", ctypes.c_uint32),
        ("node_count", ctypes.c_uint64),
        ("leaf_count", ctypes.c_uint64),
        ("primitive_count", ctypes.c_uint64),
        ("sah_cost", ctypes.c_double),
        ("memory_bytes", ctypes.c_uint64),
        ("invalid_primitive_count", ctypes.c_uint64),
        ("build_peak_bytes", ctypes.c_uint64),
        ("built_sah_cost", ctypes.c_double),
        ("build_seconds", ctypes.c_double),
        ("kept_build_bytes", ctypes.c_uint64),
    ]

    def as_dict(self):
        return {name: getattr(self, name) for name, _ in self._fields_}


class Node(ctypes.Structure):
    """A binary node: inner if count == 0 (children first, first + 1), else a leaf."""
    _fields_ = [
        ("lower", ctypes.c_float * 3),
        ("upper", ctypes.c_float * 3),
        ("first", ctypes.c_uint32),
        ("count", ctypes.c_uint32),
    ]

    def is_leaf(self):
        return self.count != 0


class Ray(ctypes.Structure):
    """Points org + t * dir for tmin <= t <= tmax."""
    _fields_ = [
        ("org", ctypes.c_float * 3),
        ("tmin", ctypes.c_float),
        ("dir", ctypes.c_float * 3),
        ("tmax", ctypes.c_float),
    ]

    def __init__(self, org=(0.0, 0.0, 0.0), dir=(0.0, 0.0, 1.0), tmin=0.0, tmax=float("inf")):
        super().__init__((ctypes.c_float * 3)(*org), tmin, (ctypes.c_float * 3)(*dir), tmax)


class Hit(ctypes.Structure):
    """prim_id is INVALID_ID on a miss (t is then inf)."""
    _fields_ = [
        ("t", ctypes.c_float),
        ("u", ctypes.c_float),
        ("v", ctypes.c_float),
        ("prim_id", ctypes.c_uint32),
    ]

    def hit(self):
        return self.prim_id != INVALID_ID


for _struct, _size in ((Stats, 88), (Node, 32), (Ray, 32), (Hit, 16)):
    assert ctypes.sizeof(_struct) == _size, (_struct.__name__, ctypes.sizeof(_struct))

#: The progress callback's C type: bool (*)(void *user_data, double fraction_done).
PROGRESS_FN = ctypes.CFUNCTYPE(ctypes.c_bool, ctypes.c_void_p, ctypes.c_double)


# ---- loading the library ----

def _load(path=None):
    path = path or os.environ.get("AACBVH_LIBRARY") or ctypes.util.find_library("aacbvh") or "libaacbvh.so.1"
    lib = ctypes.CDLL(path)
    P = ctypes.POINTER
    c_ctx, c_bvh, st = ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int
    sigs = {
        "aacbvh_version_number": (ctypes.c_uint, []),
        "aacbvh_version_string": (ctypes.c_char_p, []),
        "aacbvh_status_string": (ctypes.c_char_p, [st]),
        "aacbvh_context_create": (st, [ctypes.c_uint32, P(c_ctx)]),
        "aacbvh_context_thread_count": (ctypes.c_uint32, [c_ctx]),
        "aacbvh_context_destroy": (None, [c_ctx]),
        "aacbvh_bvh_create": (st, [c_ctx, P(c_bvh)]),
        "aacbvh_bvh_destroy": (None, [c_bvh]),
        "aacbvh_bvh_last_error": (ctypes.c_char_p, [c_bvh]),
        "aacbvh_last_error": (ctypes.c_char_p, []),
        "aacbvh_builder_name": (ctypes.c_char_p, [st]),
        "aacbvh_bvh_set_param_int": (st, [c_bvh, st, ctypes.c_int64]),
        "aacbvh_bvh_set_param_float": (st, [c_bvh, st, ctypes.c_double]),
        "aacbvh_bvh_get_param_int": (st, [c_bvh, st, P(ctypes.c_int64)]),
        "aacbvh_bvh_get_param_float": (st, [c_bvh, st, P(ctypes.c_double)]),
        "aacbvh_bvh_set_triangles": (st, [c_bvh, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t,
                                          ctypes.c_void_p, ctypes.c_size_t]),
        "aacbvh_bvh_set_boxes": (st, [c_bvh, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t]),
        "aacbvh_bvh_set_progress_callback": (st, [c_bvh, PROGRESS_FN, ctypes.c_void_p]),
        "aacbvh_bvh_build": (st, [c_bvh]),
        "aacbvh_bvh_refit": (st, [c_bvh]),
        "aacbvh_bvh_get_stats": (st, [c_bvh, P(Stats)]),
        "aacbvh_bvh_get_nodes": (st, [c_bvh, ctypes.c_size_t, ctypes.c_size_t, P(Node)]),
        "aacbvh_bvh_get_primitive_indices": (st, [c_bvh, ctypes.c_size_t, ctypes.c_size_t,
                                                  P(ctypes.c_uint32)]),
        "aacbvh_bvh_intersect": (st, [c_bvh, P(Ray), P(Hit), ctypes.c_size_t]),
        "aacbvh_bvh_occluded": (st, [c_bvh, P(Ray), P(ctypes.c_uint8), ctypes.c_size_t]),
    }
    for name, (restype, argtypes) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = restype
        fn.argtypes = argtypes
    return lib


_lib = None


def builders():
    """{name: value} of every builder the loaded library offers, from its own
    table (aacbvh_builder_name): {"aac-hq": 0, "aac-fast": 1, ...}."""
    lib, out, value = library(), {}, 0
    while True:
        name = lib.aacbvh_builder_name(value)
        if name is None:
            return out
        out[name.decode()] = value
        value += 1


def library():
    """The loaded CDLL (loaded on first use)."""
    global _lib
    if _lib is None:
        _lib = _load()
    return _lib


def version():
    """The library's version string, e.g. "1.0.0"."""
    return library().aacbvh_version_string().decode()


def version_number():
    return library().aacbvh_version_number()


def status_string(status):
    return library().aacbvh_status_string(status).decode()


def _check(status, bvh_handle=None):
    if status != OK:
        message = library().aacbvh_bvh_last_error(bvh_handle).decode() if bvh_handle else ""
        raise AacbvhError(status, status_string(status), message)


# ---- buffers ----

def _buffer(data, typecode, what):
    """(address, byte size, keep-alive object) of a C-contiguous buffer of
    4-byte items; a read-only buffer or a Python sequence is copied once."""
    import array
    if not isinstance(data, (bytes, bytearray, memoryview, array.array)) and not hasattr(data, "__array_interface__"):
        data = array.array(typecode, data)  # a list or tuple of numbers
    view = memoryview(data)
    if not view.c_contiguous:
        raise ValueError("%s must be C-contiguous" % what)
    fmt = view.format.lstrip("@=<")
    raw = fmt in ("B", "b", "c")  # plain bytes are taken as they are
    same = (fmt == typecode or (typecode == "I" and fmt in ("L", "i"))) and view.itemsize == 4
    if not raw and not same:
        raise ValueError("%s must hold 4-byte items of format %r, got %r" % (what, typecode, view.format))
    nbytes = view.nbytes
    if nbytes == 0:
        return None, 0, data
    if view.readonly:
        keep = (ctypes.c_char * nbytes).from_buffer_copy(view)
    else:
        keep = (ctypes.c_char * nbytes).from_buffer(view.cast("B"))
    return ctypes.addressof(keep), nbytes, (data, keep)


# ---- handles ----

class Context:
    """Worker threads for builds and batch queries (0 = one per core)."""

    def __init__(self, threads=0):
        self._handle = ctypes.c_void_p()
        self._bvhs = []
        _check(library().aacbvh_context_create(threads, ctypes.byref(self._handle)))

    @property
    def thread_count(self):
        return library().aacbvh_context_thread_count(self._handle)

    def close(self):
        """Destroys the context, after every Bvh created on it."""
        for bvh in list(self._bvhs):
            bvh.close()
        if self._handle:
            library().aacbvh_context_destroy(self._handle)
            self._handle = ctypes.c_void_p()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: the library may be gone
            pass


class Bvh:
    """One BVH on a Context: parameters, a reference to the geometry, the tree."""

    def __init__(self, context):
        self._context = context
        self._handle = ctypes.c_void_p()
        self._geometry = None
        self._progress = None
        _check(library().aacbvh_bvh_create(context._handle, ctypes.byref(self._handle)))
        context._bvhs.append(self)

    def close(self):
        if self._handle:
            library().aacbvh_bvh_destroy(self._handle)
            self._handle = ctypes.c_void_p()
            self._context._bvhs.remove(self)
        self._geometry = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _call(self, fn, *args):
        _check(fn(self._handle, *args), self._handle)

    # -- parameters --
    def set_param(self, param, value):
        if param in FLOAT_PARAMS:
            self._call(library().aacbvh_bvh_set_param_float, param, float(value))
        else:
            self._call(library().aacbvh_bvh_set_param_int, param, int(value))

    def get_param(self, param):
        if param in FLOAT_PARAMS:
            out = ctypes.c_double()
            self._call(library().aacbvh_bvh_get_param_float, param, ctypes.byref(out))
        else:
            out = ctypes.c_int64()
            self._call(library().aacbvh_bvh_get_param_int, param, ctypes.byref(out))
        return out.value

    # -- geometry --
    def set_triangles(self, vertices, indices=None, vertex_stride_bytes=12):
        """vertices: float32 x, y, z per vertex (any buffer, e.g. array('f') or a
        numpy float32 array; vertex_stride_bytes apart). indices: uint32, three
        per triangle, or None for triangles of consecutive vertex triples."""
        v_addr, v_bytes, v_keep = _buffer(vertices, "f", "vertices")
        vertex_count = (v_bytes + vertex_stride_bytes - 12) // vertex_stride_bytes if v_bytes else 0
        if indices is None:
            i_addr, i_keep, triangle_count = None, None, vertex_count // 3
        else:
            i_addr, i_bytes, i_keep = _buffer(indices, "I", "indices")
            if i_bytes % 12:
                raise ValueError("indices must hold three entries per triangle")
            triangle_count = i_bytes // 12
        self._call(library().aacbvh_bvh_set_triangles, v_addr, vertex_count, vertex_stride_bytes,
                   i_addr, triangle_count)
        self._geometry = (v_keep, i_keep)  # the library reads them until replaced

    def set_boxes(self, boxes, stride_bytes=24):
        """boxes: float32 min x, y, z, max x, y, z per box."""
        addr, nbytes, keep = _buffer(boxes, "f", "boxes")
        count = (nbytes + stride_bytes - 24) // stride_bytes if nbytes else 0
        self._call(library().aacbvh_bvh_set_boxes, addr, count, stride_bytes)
        self._geometry = (keep, None)

    # -- build and refit --
    def set_progress_callback(self, fn):
        """fn(fraction) -> bool, called during builds; return False to cancel
        (build() then raises AacbvhError with status ERROR_CANCELLED). An
        exception in fn also cancels. None removes it."""
        if fn is None:
            self._call(library().aacbvh_bvh_set_progress_callback, PROGRESS_FN(), None)
            self._progress = None
            return

        def trampoline(_user, fraction):
            try:
                return bool(fn(fraction))
            except BaseException:  # an exception cannot cross into C: cancel instead
                return False

        c_fn = PROGRESS_FN(trampoline)
        self._call(library().aacbvh_bvh_set_progress_callback, c_fn, None)
        self._progress = c_fn  # must outlive its use by the library

    def build(self):
        self._call(library().aacbvh_bvh_build)

    def refit(self):
        self._call(library().aacbvh_bvh_refit)

    # -- queries --
    def stats(self):
        out = Stats(struct_size=ctypes.sizeof(Stats))
        self._call(library().aacbvh_bvh_get_stats, ctypes.byref(out))
        return out

    def nodes(self, first=0, count=None):
        """A ctypes array of Node; all nodes by default."""
        if count is None:
            count = self.stats().node_count - first
        out = (Node * count)()
        self._call(library().aacbvh_bvh_get_nodes, first, count, out)
        return out

    def primitive_indices(self, first=0, count=None):
        if count is None:
            count = self.stats().primitive_count - first
        out = (ctypes.c_uint32 * count)()
        self._call(library().aacbvh_bvh_get_primitive_indices, first, count, out)
        return out

    @staticmethod
    def _rays(rays):
        if isinstance(rays, ctypes.Array) and rays._type_ is Ray:
            return rays
        if hasattr(rays, "__array_interface__") or isinstance(rays, (bytes, bytearray, memoryview)):
            view = memoryview(rays).cast("B")  # 8 float32 per ray: org, tmin, dir, tmax
            if view.nbytes % ctypes.sizeof(Ray):
                raise ValueError("a ray buffer holds 32 bytes (8 float32) per ray")
            return (Ray * (view.nbytes // ctypes.sizeof(Ray))).from_buffer_copy(view)
        rays = list(rays)
        return (Ray * len(rays))(*rays)

    def intersect(self, rays):
        """Closest hits: a ctypes array of Hit, one per ray. rays: Ray objects,
        a ctypes Ray array, or a buffer of 8 float32 per ray."""
        rays = self._rays(rays)
        hits = (Hit * len(rays))()
        self._call(library().aacbvh_bvh_intersect, rays, hits, len(rays))
        return hits

    def occluded(self, rays):
        """Any hit: a list of bools, one per ray."""
        rays = self._rays(rays)
        out = (ctypes.c_uint8 * len(rays))()
        self._call(library().aacbvh_bvh_occluded, rays, out, len(rays))
        return [bool(x) for x in out]

    def __del__(self):
        try:
            if getattr(self, "_handle", None):
                self.close()
        except Exception:  # interpreter shutdown: the library may be gone
            pass
