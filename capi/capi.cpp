// The C API: validates arguments, calls lib/, and maps every failure to an
// aacbvh_status plus a message. No exception crosses this file's functions.
#include <algorithm>
#include <cstring>
#include <mutex>
#include <new>
#include <string>
#include <system_error>
#include <thread>
#include <unordered_map>

#include "aacbvh/aacbvh.h"
#include "builder_table.h"
#include "bvh_object.h"
#include "core/error.h"
#include "core/scheduler.h"
#include "core/scratch_arena.h"

struct aacbvh_context {
    explicit aacbvh_context(unsigned threads) : scheduler(threads) {}
    aacbvh::Scheduler scheduler;
    /// Builds keep a few scratch slabs for the next ones while a context
    /// lives (core/scratch_arena.h).
    aacbvh::ScratchArena::ReserveUser scratch_reserve;
};

struct aacbvh_bvh {
    explicit aacbvh_bvh(aacbvh::Scheduler &s) : object(s) {}
    aacbvh::BvhObject object;
    /// Each thread's last failure message on this handle (as Embree keeps
    /// errors per thread): concurrent queries that fail do not overwrite each
    /// other's message. Entries are nodes, so a returned c_str() stays put
    /// while other threads add theirs.
    mutable std::mutex error_mutex;
    mutable std::unordered_map<std::thread::id, std::string> errors;
};

namespace {

using aacbvh::Error;

/// The calling thread's message for failures without a handle (aacbvh_last_error()).
thread_local std::string tls_last_error;

/// Stores `message` (or the status name when it is empty) in `slot`. Out of
/// memory for it keeps the old one, made non-empty: never "" after a failure.
void store_message(std::string &slot, aacbvh_status status, const char *message) noexcept {
    try {
        slot = (message && *message) ? message : aacbvh_status_string(status);
    } catch (...) {
        if (slot.empty()) slot.assign(1, '?');
    }
}

/// Records a failure: on the handle for this thread, or, without a handle,
/// as this thread's aacbvh_last_error().
aacbvh_status fail(const aacbvh_bvh *bvh, aacbvh_status status, const char *message) {
    if (!bvh) {
        store_message(tls_last_error, status, message);
        return status;
    }
    std::lock_guard<std::mutex> lock(bvh->error_mutex);
    try {
        store_message(bvh->errors[std::this_thread::get_id()], status, message);
    } catch (...) {
        // No memory for this thread's entry: nothing to write the message into.
    }
    return status;
}

/// Runs `body` as a C entry point: exceptions become statuses and messages.
template <class F> aacbvh_status guarded(const aacbvh_bvh *bvh, F &&body) {
    try {
        body();
        return AACBVH_OK;
    } catch (const Error &e) {
        return fail(bvh, e.status(), e.what());
    } catch (const std::bad_alloc &) {
        return fail(bvh, AACBVH_ERROR_OUT_OF_MEMORY, "out of memory");
    } catch (const std::exception &e) {
        return fail(bvh, AACBVH_ERROR_INTERNAL, e.what());
    } catch (...) {
        return fail(bvh, AACBVH_ERROR_INTERNAL, "unknown internal error");
    }
}

#define AACBVH_REQUIRE_HANDLE(bvh)                                                                                 \
    do {                                                                                                           \
        if (!(bvh)) return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "bvh is NULL");                           \
    } while (0)

#define AACBVH_REQUIRE(bvh, cond, message)                                                                         \
    do {                                                                                                           \
        if (!(cond)) return fail((bvh), AACBVH_ERROR_INVALID_ARGUMENT, (message));                                 \
    } while (0)

/// An enum value from C as a plain integer, without loading it as the C++
/// enum type (a value outside the enumerators' range would be undefined there).
template <class Enum> int32_t enum_value(const Enum &e) {
    static_assert(sizeof(Enum) == sizeof(int32_t), "enums are 32-bit");
    int32_t v;
    std::memcpy(&v, &e, sizeof v);
    return v;
}

/// Throws INVALID_ARGUMENT for a NULL `out` with entries to copy, or a range
/// [first, first + count) past `length`, naming both (`what` / `length_name`).
void check_range(size_t length, size_t first, size_t count, const void *out, const char *what,
                 const char *length_name) {
    if (count > 0 && !out) throw Error(AACBVH_ERROR_INVALID_ARGUMENT, "out is NULL");
    if (first > length || count > length - first)
        throw Error(AACBVH_ERROR_INVALID_ARGUMENT, std::string(what) + " [" + std::to_string(first) + ", " +
                                                       std::to_string(first) + " + " + std::to_string(count) +
                                                       ") is past the " + length_name + " " + std::to_string(length));
}

/// Copies entries [first, first + count) of `from` into `out` (the C API's
/// element type, of the same layout) after check_range().
template <class Array, class Out>
void copy_range(const Array &from, size_t first, size_t count, Out *out, const char *what, const char *length_name) {
    static_assert(sizeof(*from.data()) == sizeof(Out), "the C type must have the internal layout");
    check_range(from.size(), first, count, out, what, length_name);
    if (count > 0) std::memcpy(out, from.data() + first, count * sizeof(Out));
}

} // namespace

extern "C" {

unsigned aacbvh_version_number(void) { return AACBVH_VERSION_NUMBER; }
const char *aacbvh_version_string(void) { return AACBVH_VERSION_STRING; }

const char *aacbvh_status_string(aacbvh_status status) {
    switch (enum_value(status)) {
    case AACBVH_OK: return "AACBVH_OK";
    case AACBVH_ERROR_INVALID_ARGUMENT: return "AACBVH_ERROR_INVALID_ARGUMENT";
    case AACBVH_ERROR_INVALID_OPERATION: return "AACBVH_ERROR_INVALID_OPERATION";
    case AACBVH_ERROR_OUT_OF_MEMORY: return "AACBVH_ERROR_OUT_OF_MEMORY";
    case AACBVH_ERROR_INVALID_GEOMETRY: return "AACBVH_ERROR_INVALID_GEOMETRY";
    case AACBVH_ERROR_CANCELLED: return "AACBVH_ERROR_CANCELLED";
    case AACBVH_ERROR_INTERNAL: return "AACBVH_ERROR_INTERNAL";
    default: return "unknown aacbvh_status";
    }
}

const char *aacbvh_builder_name(aacbvh_builder builder) {
    const aacbvh::BuilderInfo *info = aacbvh::find_builder(enum_value(builder));
    return info ? info->name : nullptr;
}

aacbvh_status aacbvh_builder_from_name(const char *name, aacbvh_builder *out) {
    if (!name || !out) return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "name or out is NULL");
    return guarded(nullptr, [&] {
        size_t count;
        const aacbvh::BuilderInfo *table = aacbvh::builder_table(count);
        std::string known;
        for (size_t i = 0; i < count; ++i) {
            if (std::strcmp(table[i].name, name) == 0) {
                *out = table[i].value;
                return;
            }
            known += (i ? ", " : "") + std::string(table[i].name);
        }
        throw Error(AACBVH_ERROR_INVALID_ARGUMENT, "unknown builder '" + std::string(name) + "' (builders: " + known + ")");
    });
}

aacbvh_status aacbvh_context_create(uint32_t thread_count, aacbvh_context **out) {
    if (!out) return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "out is NULL");
    *out = nullptr;
    if (thread_count > 1024)
        return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "thread_count must be at most 1024 (0 = one per core)");
    unsigned threads = thread_count;
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    return guarded(nullptr, [&] {
        try {
            *out = new aacbvh_context(threads);
        } catch (const std::system_error &e) {
            // The system's threads are a resource like memory: out of them, out of memory.
            throw Error(AACBVH_ERROR_OUT_OF_MEMORY,
                        "could not start " + std::to_string(threads) + " threads: " + e.what());
        }
    });
}

uint32_t aacbvh_context_thread_count(const aacbvh_context *context) {
    return context ? context->scheduler.thread_count() : 0;
}

void aacbvh_context_destroy(aacbvh_context *context) { delete context; }

aacbvh_status aacbvh_bvh_create(aacbvh_context *context, aacbvh_bvh **out) {
    if (!out) return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "out is NULL");
    *out = nullptr;
    if (!context) return fail(nullptr, AACBVH_ERROR_INVALID_ARGUMENT, "context is NULL");
    return guarded(nullptr, [&] { *out = new aacbvh_bvh(context->scheduler); });
}

void aacbvh_bvh_destroy(aacbvh_bvh *bvh) { delete bvh; }

const char *aacbvh_bvh_last_error(const aacbvh_bvh *bvh) {
    if (!bvh) return "invalid handle";
    std::lock_guard<std::mutex> lock(bvh->error_mutex);
    const auto it = bvh->errors.find(std::this_thread::get_id());
    return it == bvh->errors.end() ? "" : it->second.c_str();
}

const char *aacbvh_last_error(void) { return tls_last_error.c_str(); }

aacbvh_status aacbvh_bvh_set_param_int(aacbvh_bvh *bvh, aacbvh_param param, int64_t value) {
    AACBVH_REQUIRE_HANDLE(bvh);
    const int32_t key = enum_value(param);
    return guarded(bvh, [&] { bvh->object.set_param_int(key, value); });
}

aacbvh_status aacbvh_bvh_set_param_float(aacbvh_bvh *bvh, aacbvh_param param, double value) {
    AACBVH_REQUIRE_HANDLE(bvh);
    const int32_t key = enum_value(param);
    return guarded(bvh, [&] { bvh->object.set_param_float(key, value); });
}

aacbvh_status aacbvh_bvh_get_param_int(const aacbvh_bvh *bvh, aacbvh_param param, int64_t *out) {
    AACBVH_REQUIRE_HANDLE(bvh);
    AACBVH_REQUIRE(bvh, out, "out is NULL");
    const int32_t key = enum_value(param);
    return guarded(bvh, [&] { *out = bvh->object.params.get_int(key); });
}

aacbvh_status aacbvh_bvh_get_param_float(const aacbvh_bvh *bvh, aacbvh_param param, double *out) {
    AACBVH_REQUIRE_HANDLE(bvh);
    AACBVH_REQUIRE(bvh, out, "out is NULL");
    const int32_t key = enum_value(param);
    return guarded(bvh, [&] { *out = bvh->object.params.get_float(key); });
}

aacbvh_status aacbvh_bvh_set_triangles(aacbvh_bvh *bvh, const float *vertices, size_t vertex_count,
                                       size_t vertex_stride_bytes, const uint32_t *indices, size_t triangle_count) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] {
        bvh->object.set_triangles(vertices, vertex_count, vertex_stride_bytes, indices, triangle_count);
    });
}

aacbvh_status aacbvh_bvh_set_boxes(aacbvh_bvh *bvh, const float *boxes, size_t box_count, size_t stride_bytes) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] { bvh->object.set_boxes(boxes, box_count, stride_bytes); });
}

aacbvh_status aacbvh_bvh_set_progress_callback(aacbvh_bvh *bvh, aacbvh_progress_fn fn, void *user_data) {
    AACBVH_REQUIRE_HANDLE(bvh);
    bvh->object.set_progress(fn, user_data);
    return AACBVH_OK;
}

aacbvh_status aacbvh_bvh_build(aacbvh_bvh *bvh) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] { bvh->object.build(); });
}

aacbvh_status aacbvh_bvh_refit(aacbvh_bvh *bvh) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] { bvh->object.refit(); });
}

aacbvh_status aacbvh_bvh_optimize(aacbvh_bvh *bvh, uint32_t passes) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] { bvh->object.optimize(passes); });
}

aacbvh_status aacbvh_bvh_get_stats(const aacbvh_bvh *bvh, aacbvh_stats *out) {
    AACBVH_REQUIRE_HANDLE(bvh);
    AACBVH_REQUIRE(bvh, out, "out is NULL");
    // The first published struct ended after memory_bytes; older callers get what fits.
    const size_t minimum = offsetof(aacbvh_stats, memory_bytes) + sizeof(out->memory_bytes);
    if (out->struct_size < minimum)
        return fail(bvh, AACBVH_ERROR_INVALID_ARGUMENT,
                    "stats->struct_size is too small: set it to sizeof(aacbvh_stats) before the call");
    return guarded(bvh, [&] {
        aacbvh_stats full;
        std::memset(&full, 0, sizeof full);
        bvh->object.stats(full);
        const size_t n = std::min<size_t>(out->struct_size, sizeof full);
        const uint32_t size = out->struct_size;
        std::memcpy(out, &full, n);
        out->struct_size = size;
    });
}

aacbvh_status aacbvh_bvh_get_nodes(const aacbvh_bvh *bvh, size_t first, size_t count, aacbvh_node *out) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] {
        bvh->object.require_tree();
        check_range(bvh->object.node_count(), first, count, out, "node range", "node count");
        static_assert(sizeof(aacbvh::Node) == sizeof(aacbvh_node), "the C type must have the internal layout");
        bvh->object.copy_nodes(first, count, out);
    });
}

aacbvh_status aacbvh_bvh_get_primitive_indices(const aacbvh_bvh *bvh, size_t first, size_t count, uint32_t *out) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] {
        bvh->object.require_tree();
        copy_range(bvh->object.primitive_indices(), first, count, out, "index range", "primitive count");
    });
}

aacbvh_status aacbvh_bvh_intersect(const aacbvh_bvh *bvh, const aacbvh_ray *rays, aacbvh_hit *hits, size_t count) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] {
        if (count > 0 && (!rays || !hits)) throw Error(AACBVH_ERROR_INVALID_ARGUMENT, "rays or hits is NULL");
        bvh->object.require_tree();
        bvh->object.intersect(rays, hits, count);
    });
}

aacbvh_status aacbvh_bvh_occluded(const aacbvh_bvh *bvh, const aacbvh_ray *rays, uint8_t *out, size_t count) {
    AACBVH_REQUIRE_HANDLE(bvh);
    return guarded(bvh, [&] {
        if (count > 0 && (!rays || !out)) throw Error(AACBVH_ERROR_INVALID_ARGUMENT, "rays or out is NULL");
        bvh->object.require_tree();
        bvh->object.occluded(rays, out, count);
    });
}

} // extern "C"
