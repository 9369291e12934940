"""A small ctypes binding of libaacbvh (no compiled extension; numpy optional).

    import numpy, aacbvh
    vertices = numpy.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=numpy.float32)
    with aacbvh.Context() as ctx, aacbvh.Bvh(ctx) as bvh:
        bvh.set_param(aacbvh.PARAM_BUILDER, aacbvh.BUILDER_AAC_FAST)
        bvh.set_triangles(vertices)          # referenced, not copied
        bvh.build()
        hits = bvh.intersect(aacbvh.make_rays([[0.2, 0.2, 1]], [[0, 0, -1]]))
        print(hits["prim_id"][0], hits["t"][0], bvh.stats().sah_cost)

Without numpy, array.array("f", ...) geometry and a list of aacbvh.Ray work
the same way; intersect() then returns a ctypes array of Hit.

Install: pip install ./examples/python, in a virtual environment (README.md,
"From Python", has the command that works offline). The library
libaacbvh.so.1 is loaded on first use from $AACBVH_LIBRARY if that is set,
else from next to this file, else from the system's library path (after
`cmake --install build` and `ldconfig`); when none loads, LibraryLoadError
(an OSError) says what was tried and how to fix it.

Arguments are checked before they reach the library: a wrong element type
raises TypeError and a wrong shape, stride, size or memory layout ValueError,
each naming what was expected and what came. Buffers follow the C API's
lifetime rule: the library keeps pointers into the geometry, so the Bvh keeps a
reference to each array it was given. A numpy float32 / uint32 array (or an
array.array, bytearray) is used in place, never copied, so moving its
vertices and calling refit() works; bytes and Python lists are copied once.
Every failing library call raises AacbvhError, which carries the status and
the library's message. The header include/aacbvh/aacbvh.h is the manual; the
names here are its names without the aacbvh_ prefix.
"""

import array
import ctypes
import numbers
import os
import sys

__version__ = "1.2.0"  # the library version this binding follows (aacbvh.h)

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
PARAM_OPTIMIZE_PASSES = 12  # since 1.2

LAYOUT_BINARY = 0
LAYOUT_WIDE4 = 1
LAYOUT_WIDE8 = 2

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

#: The file name (soname) of the library this binding follows.
LIBRARY_NAME = "libaacbvh.so.1"

_INSTALL_HINT = ("Point AACBVH_LIBRARY at the library (export AACBVH_LIBRARY=/path/to/%s, "
                 "e.g. build/capi/%s of a CMake build), or install it where the system "
                 "finds it (cmake --install build, then ldconfig)." % (LIBRARY_NAME, LIBRARY_NAME))


class LibraryLoadError(OSError):
    """libaacbvh could not be loaded (or lacks a function this binding needs).
    .tried is the list of (path, where it came from, why it failed)."""

    def __init__(self, message, tried):
        super().__init__(message)
        self.tried = tried


def library_candidates():
    """The (path, origin) pairs the binding tries, in order: $AACBVH_LIBRARY
    alone when it is set; otherwise libaacbvh.so.1 next to this file (where a
    packager may put it), then the system's search (LD_LIBRARY_PATH, the
    ldconfig cache, /lib, /usr/lib)."""
    env = os.environ.get("AACBVH_LIBRARY")
    if env:
        return [(env, "$AACBVH_LIBRARY")]
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), LIBRARY_NAME)
    out = [(here, "next to %s" % os.path.basename(__file__))] if os.path.exists(here) else []
    out.append((LIBRARY_NAME, "the system's library search"))
    return out


def _load(path=None):
    P = ctypes.POINTER
    c_ctx, c_bvh, st, ptr = ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p
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
        "aacbvh_bvh_set_triangles": (st, [c_bvh, ptr, ctypes.c_size_t, ctypes.c_size_t,
                                          ptr, ctypes.c_size_t]),
        "aacbvh_bvh_set_boxes": (st, [c_bvh, ptr, ctypes.c_size_t, ctypes.c_size_t]),
        "aacbvh_bvh_set_progress_callback": (st, [c_bvh, PROGRESS_FN, ctypes.c_void_p]),
        "aacbvh_bvh_build": (st, [c_bvh]),
        "aacbvh_bvh_refit": (st, [c_bvh]),
        "aacbvh_bvh_optimize": (st, [c_bvh, ctypes.c_uint32]),
        "aacbvh_bvh_get_stats": (st, [c_bvh, P(Stats)]),
        "aacbvh_bvh_get_nodes": (st, [c_bvh, ctypes.c_size_t, ctypes.c_size_t, P(Node)]),
        "aacbvh_bvh_get_primitive_indices": (st, [c_bvh, ctypes.c_size_t, ctypes.c_size_t,
                                                  P(ctypes.c_uint32)]),
        "aacbvh_bvh_intersect": (st, [c_bvh, ptr, ptr, ctypes.c_size_t]),
        "aacbvh_bvh_occluded": (st, [c_bvh, ptr, ptr, ctypes.c_size_t]),
    }
    candidates = [(path, "the path given")] if path else library_candidates()
    tried = []
    for candidate, origin in candidates:
        try:
            lib = ctypes.CDLL(candidate)
        except OSError as e:
            tried.append((candidate, origin, str(e)))
            continue
        for name, (restype, argtypes) in sigs.items():
            try:
                fn = getattr(lib, name)
            except AttributeError:
                raise LibraryLoadError(
                    "%s (from %s) lacks %s(): it is not a libaacbvh this binding (%s) can use. %s"
                    % (candidate, origin, name, __version__, _INSTALL_HINT),
                    tried + [(candidate, origin, "lacks %s" % name)]) from None
            fn.restype = restype
            fn.argtypes = argtypes
        return lib
    raise LibraryLoadError(
        "cannot load libaacbvh; tried %s. %s"
        % ("; ".join("%s (%s): %s" % t for t in tried), _INSTALL_HINT), tried)


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
    """The loaded CDLL, loaded on first use (see library_candidates());
    raises LibraryLoadError when no candidate loads."""
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


# ---- checking and passing arrays ----
#
# numpy is never imported here: an argument is a numpy array only if numpy is
# already loaded (the caller made the array), and numpy results come only for
# numpy input.

def _numpy_of(obj):
    np = sys.modules.get("numpy")
    return np if np is not None and isinstance(obj, (np.ndarray, np.generic)) else None


def _describe(obj):
    """What came, for error messages: "float64 (4, 8)", "array('d') of 9 items"."""
    if _numpy_of(obj) is not None:
        return "%s %s" % (obj.dtype, tuple(obj.shape))
    if isinstance(obj, array.array):
        return "array(%r) of %d items" % (obj.typecode, len(obj))
    if isinstance(obj, memoryview):
        return "a memoryview of format %r, shape %s" % (obj.format, tuple(obj.shape))
    if isinstance(obj, (bytes, bytearray)):
        return "%s of %d bytes" % (type(obj).__name__, len(obj))
    return type(obj).__name__


class _Spec:
    """One geometry argument of the C API: `what` holds elements of `width`
    float32 or uint32 numbers; numpy arrays of shape (n,) + one of
    `element_shapes`, or flat; `stride_name` is the keyword that sets how far
    apart elements are (None: always packed)."""

    def __init__(self, what, width, is_float, element_shapes, stride_name=None):
        self.what, self.width, self.is_float = what, width, is_float
        self.element_shapes = element_shapes
        self.stride_name = stride_name
        item = "float32" if is_float else "uint32"
        shapes = " or ".join("(n, %s)" % ", ".join(map(str, s)) for s in element_shapes)
        self.expected = "%s must be %s with shape %s or (%d n,)" % (what, item, shapes, width)

    def type_error(self, obj, extra=""):
        return TypeError("%s%s; got %s" % (self.expected, extra, _describe(obj)))

    def value_error(self, obj, why):
        return ValueError("%s, %s; got %s" % (self.expected, why, _describe(obj)))

    def formats(self):
        return ("f",) if self.is_float else ("I", "i", "L", "l")

    def check_stride(self, stride):
        if stride is None:
            return None
        if isinstance(stride, bool) or not isinstance(stride, int):
            raise TypeError("%s must be an int (bytes); got %s" % (self.stride_name, type(stride).__name__))
        if stride < 4 * self.width or stride % 4:
            raise ValueError("%s must be a multiple of 4 and at least %d; got %d"
                             % (self.stride_name, 4 * self.width, stride))
        return stride

    def count(self, obj, nbytes, stride):
        """Elements in nbytes at stride (the last one may lack its padding)."""
        if nbytes == 0:
            return 0
        full, rest = divmod(nbytes, stride)
        if rest == 0:
            return full
        if rest >= 4 * self.width:
            return full + 1
        raise self.value_error(obj, "and %d bytes are not a whole number of %d-byte elements %d bytes apart"
                               % (nbytes, 4 * self.width, stride))


def _address_of(obj, view):
    """(address, keep-alive) of a C-contiguous buffer: a read-only one (bytes)
    is copied once, a writable one used in place."""
    if view.nbytes == 0:
        return None, obj
    if view.readonly:
        keep = (ctypes.c_char * view.nbytes).from_buffer_copy(view)
    else:
        keep = (ctypes.c_char * view.nbytes).from_buffer(view.cast("B"))
    return ctypes.addressof(keep), (obj, keep)


def _flatten(data, spec):
    """A Python sequence of numbers, or of `width`-sequences, copied into an array.array."""
    try:
        items = list(data)
    except TypeError:
        raise spec.type_error(data) from None
    if items and not isinstance(items[0], numbers.Real):
        flat = []
        for item in items:
            try:
                if isinstance(item, (str, bytes)):
                    raise TypeError
                row = list(item)
            except TypeError:
                raise spec.type_error(data, " (or a sequence of numbers, or of %d-sequences)" % spec.width) from None
            if len(row) != spec.width:
                raise spec.value_error(data, "but an element has %d numbers" % len(row))
            flat.extend(row)
        items = flat
    try:
        return array.array("f" if spec.is_float else "I", items)
    except TypeError:
        raise spec.type_error(data, " (or a sequence of numbers, or of %d-sequences)" % spec.width) from None
    except OverflowError:
        raise spec.value_error(data, "but a value is outside the uint32 range") from None


def _array_arg(data, spec, stride=None):
    """(address, element count, stride in bytes, keep-alive) of one geometry
    argument, checked against spec. numpy arrays and writable buffers are used
    in place; bytes and Python sequences are copied once."""
    stride = spec.check_stride(stride)
    np = _numpy_of(data)
    if np is not None:
        return _numpy_arg(np, data, spec, stride)
    if not isinstance(data, (bytes, bytearray, memoryview, array.array)):
        try:
            memoryview(data)  # another object with the buffer protocol
        except TypeError:
            data = _flatten(data, spec)
    view = memoryview(data)
    fmt = view.format.lstrip("@=<")
    raw = fmt in ("B", "b", "c")  # plain bytes are taken as they are
    if not raw and (fmt not in spec.formats() or view.itemsize != 4):
        raise spec.type_error(data)
    if not view.c_contiguous:
        raise spec.value_error(data, "but the buffer is not C-contiguous")
    if view.nbytes % 4:
        raise spec.value_error(data, "but %d bytes are not a whole number of 4-byte items" % view.nbytes)
    step = stride or 4 * spec.width
    count = spec.count(data, view.nbytes, step)
    address, keep = _address_of(data, view)
    if address is not None and address % 4:
        raise spec.value_error(data, "but the buffer is not 4-byte aligned")
    return address, count, step, keep


def _numpy_arg(np, arr, spec, stride):
    """A numpy array, used in place: flat and contiguous, or (n,) + an element
    shape, C-contiguous, or (for an argument with a stride) with elements
    packed and rows any multiple of 4 bytes apart, like arr[:, :3] of an (n, 8) array."""
    ok_types = (np.float32,) if spec.is_float else (np.uint32, np.int32)
    if not any(arr.dtype == t for t in ok_types):  # byte-swapped types differ too
        raise spec.type_error(arr)
    if arr.ndim == 0:
        raise spec.value_error(arr, "but it is a scalar")
    address = arr.__array_interface__["data"][0]
    if arr.size and address % 4:
        raise spec.value_error(arr, "but the array is not 4-byte aligned")
    copy_hint = "; numpy.ascontiguousarray() makes a copy that is"
    if arr.ndim == 1:
        if arr.size > 1 and arr.strides[0] != 4:
            raise spec.value_error(arr, "but the array is not contiguous (strides %s)%s"
                                   % (arr.strides, copy_hint))
        step = stride or 4 * spec.width
        return (address if arr.size else None), spec.count(arr, arr.nbytes, step), step, arr
    if not any(arr.ndim == len(s) + 1 and tuple(arr.shape[1:]) == s for s in spec.element_shapes):
        raise spec.value_error(arr, "but the shape does not fit")
    if arr.flags.c_contiguous:
        row = 4 * spec.width
    elif spec.stride_name is None or arr.ndim != 2:
        raise spec.value_error(arr, "but the array is not C-contiguous (strides %s)%s" % (arr.strides, copy_hint))
    else:
        row = arr.strides[0]
        if arr.strides[1] != 4 or row < 4 * spec.width or row % 4:
            raise spec.value_error(arr, "but its rows are not packed float32 a multiple of 4 bytes apart "
                                   "(strides %s)%s" % (arr.strides, copy_hint))
    if stride is not None and stride != row:
        raise ValueError("%s = %d does not match the array's rows, %d bytes apart (strides %s); leave it out "
                         "for a numpy array of shape (n, ...)" % (spec.stride_name, stride, row, arr.strides))
    count = arr.size // spec.width  # (n, 3, 3) triangles are 3 n vertices
    return (address if count else None), count, row, arr


_VERTICES = _Spec("vertices", 3, True, ((3,), (3, 3)), "vertex_stride_bytes")
_INDICES = _Spec("indices", 3, False, ((3,),))
_BOXES = _Spec("boxes", 6, True, ((6,), (2, 3)), "stride_bytes")

_RAYS_EXPECTED = "rays must be float32 with shape (n, 8) or a sequence of Ray"


def _rays_arg(rays):
    """(address, count, numpy module for numpy input else None, keep-alive).
    Rays are read only during the call, so a numpy array that is not
    C-contiguous is copied rather than refused."""
    if isinstance(rays, ctypes.Array) and rays._type_ is Ray:
        return ctypes.addressof(rays), len(rays), None, rays
    np = _numpy_of(rays)
    if np is not None:
        if rays.dtype.names is not None:
            if rays.dtype != np.dtype(RAY_DTYPE_FIELDS):
                raise TypeError("%s, or a RAY_DTYPE array; got a structured array of %s"
                                % (_RAYS_EXPECTED, rays.dtype))
            if rays.ndim != 1:
                raise ValueError("%s, or a RAY_DTYPE array of shape (n,); got RAY_DTYPE %s"
                                 % (_RAYS_EXPECTED, tuple(rays.shape)))
        elif rays.dtype != np.float32:
            raise TypeError("%s; got %s" % (_RAYS_EXPECTED, _describe(rays)))
        elif rays.ndim != 2 or rays.shape[1] != 8:
            raise ValueError("%s; got %s" % (_RAYS_EXPECTED, _describe(rays)))
        rays = np.require(rays, requirements=("C", "A"))
        return rays.__array_interface__["data"][0], rays.shape[0], np, rays
    if isinstance(rays, (bytes, bytearray, memoryview, array.array)):
        view = memoryview(rays)
        fmt = view.format.lstrip("@=<")
        if not (fmt in ("B", "b", "c") or (fmt == "f" and view.itemsize == 4)):
            raise TypeError("%s; got %s" % (_RAYS_EXPECTED, _describe(rays)))
        if not view.c_contiguous or view.nbytes % ctypes.sizeof(Ray):
            raise ValueError("%s (a buffer holds 8 float32, 32 bytes, per ray); got %s"
                             % (_RAYS_EXPECTED, _describe(rays)))
        keep = (Ray * (view.nbytes // ctypes.sizeof(Ray))).from_buffer_copy(view)
        return ctypes.addressof(keep), len(keep), None, keep
    try:
        rays = list(rays)
    except TypeError:
        raise TypeError("%s; got %s" % (_RAYS_EXPECTED, _describe(rays))) from None
    for ray in rays:
        if not isinstance(ray, Ray):
            raise TypeError("%s; got a %s holding %s" % (_RAYS_EXPECTED, type(rays).__name__, type(ray).__name__))
    keep = (Ray * len(rays))(*rays)
    return ctypes.addressof(keep), len(keep), None, keep


# ---- numpy helpers (numpy imported on first use) ----

#: aacbvh_ray and aacbvh_hit as numpy structured dtype field lists.
RAY_DTYPE_FIELDS = [("org", "=f4", (3,)), ("tmin", "=f4"), ("dir", "=f4", (3,)), ("tmax", "=f4")]
HIT_DTYPE_FIELDS = [("t", "=f4"), ("u", "=f4"), ("v", "=f4"), ("prim_id", "=u4")]


def __getattr__(name):
    """aacbvh.RAY_DTYPE and aacbvh.HIT_DTYPE: the numpy dtypes, made (and numpy
    imported) when first asked for."""
    if name in ("RAY_DTYPE", "HIT_DTYPE"):
        import numpy
        dtype = numpy.dtype(RAY_DTYPE_FIELDS if name == "RAY_DTYPE" else HIT_DTYPE_FIELDS)
        globals()[name] = dtype
        return dtype
    raise AttributeError("module %r has no attribute %r" % (__name__, name))


def make_rays(org, dir, tmin=0.0, tmax=float("inf")):
    """A numpy (n, 8) float32 ray array (org, tmin, dir, tmax per row) from
    origins and directions of shape (n, 3) or (3,) (broadcast to the other's
    n), and tmin, tmax (numbers or arrays of n)."""
    import numpy
    org = numpy.asarray(org, dtype=numpy.float32).reshape(-1, 3)
    dir = numpy.asarray(dir, dtype=numpy.float32).reshape(-1, 3)
    out = numpy.empty((max(len(org), len(dir)), 8), dtype=numpy.float32)
    out[:, 0:3] = org
    out[:, 3] = tmin
    out[:, 4:7] = dir
    out[:, 7] = tmax
    return out


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
    def set_triangles(self, vertices, indices=None, vertex_stride_bytes=None):
        """vertices: float32 x, y, z per vertex: a numpy array of shape (n, 3)
        (rows may be any multiple of 4 bytes apart, like positions[:, :3] of an
        (n, 8) array), (t, 3, 3) or flat, an array.array("f"), another float32
        buffer, or a sequence of numbers or of (x, y, z). vertex_stride_bytes:
        bytes from one vertex to the next in a flat buffer (default 12; for a
        numpy (n, 3) array it is read from the array). indices: uint32 (numpy
        uint32 or int32), three per triangle, shape (m, 3) or flat; None for
        triangles of consecutive vertex triples. Arrays are used in place and
        kept referenced until the geometry is replaced: move vertices in the
        array, then refit()."""
        v_addr, vertex_count, stride, v_keep = _array_arg(vertices, _VERTICES, vertex_stride_bytes)
        if indices is None:
            if vertex_count % 3:
                raise ValueError("without indices, vertices must hold whole triangles (3 vertices each); got %d "
                                 "vertices from %s" % (vertex_count, _describe(vertices)))
            i_addr, i_keep, triangle_count = None, None, vertex_count // 3
        else:
            i_addr, triangle_count, _, i_keep = _array_arg(indices, _INDICES)
        self._call(library().aacbvh_bvh_set_triangles, v_addr, vertex_count, stride, i_addr, triangle_count)
        self._geometry = (v_keep, i_keep)  # the library reads them until replaced

    def set_boxes(self, boxes, stride_bytes=None):
        """boxes: float32 min x, y, z, max x, y, z per box: a numpy array of
        shape (n, 6) (rows may be any multiple of 4 bytes apart) or (n, 2, 3)
        or flat, an array.array("f"), another float32 buffer, or a sequence.
        stride_bytes: bytes from one box to the next in a flat buffer (default 24)."""
        addr, count, stride, keep = _array_arg(boxes, _BOXES, stride_bytes)
        self._call(library().aacbvh_bvh_set_boxes, addr, count, stride)
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

    def optimize(self, passes=1):
        """Improves the current tree in place (library 1.2 and later)."""
        self._call(library().aacbvh_bvh_optimize, int(passes))

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

    def intersect(self, rays):
        """Closest hit of each ray. rays: a numpy float32 array of shape (n, 8)
        (org, tmin, dir, tmax per row; make_rays() builds one) or of RAY_DTYPE:
        returns a numpy array of HIT_DTYPE (fields t, u, v, prim_id; prim_id is
        INVALID_ID on a miss). A sequence of Ray, a ctypes Ray array or a
        buffer of 8 float32 per ray: returns a ctypes array of Hit."""
        address, count, np, keep = _rays_arg(rays)
        if np is not None:
            hits = np.empty(count, dtype=np.dtype(HIT_DTYPE_FIELDS))
            out = hits.__array_interface__["data"][0]
        else:
            hits = (Hit * count)()
            out = ctypes.addressof(hits)
        self._call(library().aacbvh_bvh_intersect, address if count else None, out if count else None, count)
        return hits

    def occluded(self, rays):
        """Whether anything lies on each ray (any hit): a numpy bool array for
        numpy rays, else a list of bools. rays: as for intersect()."""
        address, count, np, keep = _rays_arg(rays)
        if np is not None:
            out = np.empty(count, dtype=np.bool_)  # the library writes 0 or 1, numpy's bool bytes
            out_address = out.__array_interface__["data"][0]
        else:
            out = (ctypes.c_uint8 * count)()
            out_address = ctypes.addressof(out)
        self._call(library().aacbvh_bvh_occluded, address if count else None, out_address if count else None,
                   count)
        return out if np is not None else [bool(x) for x in out]

    def __del__(self):
        try:
            if getattr(self, "_handle", None):
                self.close()
        except Exception:  # interpreter shutdown: the library may be gone
            pass
