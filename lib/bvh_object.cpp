#include "bvh_object.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "build/binary_tree.h"
#include "build/build_context.h"
#include "build/build_input.h"
#include "build/flatten.h"
#include "builder_table.h"
#include "bvh/bvh_refit.h"
#include "bvh/bvh_stats.h"
#include "core/error.h"
#include "core/memory.h"
#include "optimize/treelet_optimizer.h"
#include "trace/traversal.h"
#include "trace/wide_traversal.h"
#include "trace/wide8_traversal.h"

namespace aacbvh {

namespace {

[[noreturn]] void reject(const std::string &what) { throw Error(AACBVH_ERROR_INVALID_ARGUMENT, what); }

/// Largest primitive count: the builders' binary trees number their 2n - 1
/// nodes with 32-bit ids, so 2n - 1 must stay below 2^32.
constexpr size_t kMaxPrimitives = AACBVH_MAX_PRIMITIVES;
static_assert(2 * uint64_t(kMaxPrimitives) - 1 < (uint64_t(1) << 32), "node ids must fit 32 bits");

void check_stride(size_t stride, size_t minimum, const char *what) {
    if (stride < minimum || stride % 4 != 0)
        reject(std::string(what) + " stride " + std::to_string(stride) + " must be >= " + std::to_string(minimum) +
               " and a multiple of 4");
}

} // namespace

/// The block cache of one build or optimisation. With
/// AACBVH_PARAM_KEEP_BUILD_MEMORY, big blocks come from and go back to the
/// handle's cache for the whole operation, the replaced tree's included;
/// whatever the operation did not reuse is freed when it ends, failed or not.
/// Without it, the handle's cache is dropped and the operation uses one of
/// its own, freed when it ends.
class BvhObject::KeptMemory {
public:
    KeptMemory(std::unique_ptr<BlockCache> &kept, bool keep) : cache_(prepare(kept, keep, local_)), scope_(cache_) {}
    ~KeptMemory() {
        if (cache_ != &local_) cache_->end_build(); // the handle's: keep what this build freed
    }
    KeptMemory(const KeptMemory &) = delete;
    KeptMemory &operator=(const KeptMemory &) = delete;

private:
    /// With keep, the handle's cache; without, one that lives for this build
    /// only: the arrays a build frees early (Morton codes, the binary tree)
    /// serve the ones it allocates later (the layouts), and what is left goes
    /// back to the system when the build ends.
    static BlockCache *prepare(std::unique_ptr<BlockCache> &kept, bool keep, BlockCache &local) {
        if (!keep) {
            kept.reset();
            return &local;
        }
        if (!kept) kept.reset(new BlockCache());
        kept->begin_build();
        return kept.get();
    }
    BlockCache local_; // declared first: prepare() hands it out
    BlockCache *cache_;
    BlockCache::Scope scope_;
};

namespace {

/// A build's (or an optimisation's) fresh pages cleared on every thread of
/// its context, where it has more than one (core/scheduler.h), while it lives.
class BuildPageMapping {
public:
    explicit BuildPageMapping(Scheduler &scheduler)
        : mapper_(scheduler), scope_(scheduler.thread_count() > 1 ? &mapper_ : nullptr) {}

private:
    const ParallelPageMapper mapper_; // declared first: scope_ installs it
    const PageMapper::Scope scope_;
};

} // namespace

void BvhObject::require_idle() const {
    if (building_)
        throw Error(AACBVH_ERROR_INVALID_OPERATION,
                    "this BVH is being built: its progress callback may query it or use other handles, not change it");
}

void BvhObject::replace_geometry(const Geometry &g) {
    geometry_ = g;
    geometry_set_ = true;
    valid_ = false; // queries wait for the next build or refit
}

void BvhObject::set_triangles(const float *vertices, size_t vertex_count, size_t vertex_stride,
                              const uint32_t *indices, size_t triangle_count) {
    require_idle();
    if (triangle_count > kMaxPrimitives) reject("triangle count " + std::to_string(triangle_count) +
                                                    " exceeds AACBVH_MAX_PRIMITIVES (2^31 - 1)");
    if (vertex_count > (size_t(1) << 32)) reject("vertex count exceeds 2^32");
    if (triangle_count > 0 && vertex_count == 0) reject("triangles need vertices: vertex_count is 0");
    if (!vertices && vertex_count > 0) reject("vertices is NULL but vertex_count is " + std::to_string(vertex_count));
    if (vertex_count > 0) check_stride(vertex_stride, 3 * sizeof(float), "vertex");
    if (vertex_count > 0 && vertex_stride > std::numeric_limits<size_t>::max() / vertex_count)
        reject("vertex_count * vertex_stride overflows");
    if (!indices && triangle_count > vertex_count / 3)
        reject("without indices, " + std::to_string(triangle_count) + " triangles need " +
               std::to_string(3 * uint64_t(triangle_count)) + " vertices, got " + std::to_string(vertex_count));
    Geometry g;
    g.kind = GeometryKind::Triangles;
    g.vertices = vertices;
    g.vertex_count = vertex_count;
    g.vertex_stride = vertex_stride;
    g.indices = indices;
    g.primitive_count = triangle_count;
    replace_geometry(g);
}

void BvhObject::set_boxes(const float *boxes, size_t box_count, size_t stride) {
    require_idle();
    if (box_count > kMaxPrimitives) reject("box count " + std::to_string(box_count) + " exceeds AACBVH_MAX_PRIMITIVES (2^31 - 1)");
    if (!boxes && box_count > 0) reject("boxes is NULL but box_count is " + std::to_string(box_count));
    if (box_count > 0) check_stride(stride, 6 * sizeof(float), "box");
    if (box_count > 0 && stride > std::numeric_limits<size_t>::max() / box_count) reject("box_count * stride overflows");
    Geometry g;
    g.kind = GeometryKind::Boxes;
    g.boxes = boxes;
    g.box_stride = stride;
    g.primitive_count = box_count;
    replace_geometry(g);
}

void BvhObject::copy_triangles(const Bvh &bvh, float *out) const {
    const uint32_t *ids = bvh.prim_ids.data();
    scheduler_.parallel_for(0, bvh.prim_ids.size(), size_t(1) << 12, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            const float *p[3];
            geometry_.triangle(ids[i], p);
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) out[9 * i + 3 * k + a] = p[k][a];
        }
    });
}

void BvhObject::set_param_int(int32_t key, int64_t value) {
    require_idle();
    params.set_int(key, value);
    if (!params.keep_build_memory) kept_blocks_.reset();
}

void BvhObject::build() {
    require_idle();
    struct Building {
        bool &flag;
        explicit Building(bool &f) : flag(f) { flag = true; }
        ~Building() { flag = false; }
    } building(building_);
    const auto start = std::chrono::steady_clock::now();
    const KeptMemory kept(kept_blocks_, params.keep_build_memory);
    // The build's mid-size scratch in huge-page slabs (core/scratch_arena.h);
    // the arrays the handle keeps are made with it set aside.
    ScratchArena scratch;
    const ScratchArena::Scope scratch_scope(&scratch);

    const BuildPageMapping page_mapping(scheduler_);
    BuildContext ctx(scheduler_, progress_, progress_user_);
    ctx.report(0.0);

    // Everything the build allocates is counted from here (build_peak_bytes).
    MemoryMeter meter;
    Bvh result;
    Layouts layouts;
    bool made = false; // the layouts, straight from the builder's tree
    uint64_t invalid_count = 0;
    {
        const MemoryMeter::Scope metered(meter);
        const BuilderInfo *builder = find_builder(params.builder);
        if (!builder) throw Error(AACBVH_ERROR_INTERNAL, "unknown builder " + std::to_string(int(params.builder)));
        BuildInput input;
        compute_build_input(geometry_, params.skip_invalid, ctx, input, InputPath::Fastest, builder->input_room);
        invalid_count = input.invalid_count;
        ctx.report(0.1);

        if (input.size() > 0) {
            const bool straight = straight_to_compact(input.size());
            const FlattenRule rule{params.max_leaf_size, params.traversal_cost, params.intersection_cost, straight,
                                   extent_scale_of(input.bounds)};
            BinaryTree tree;
            SubtreeChoices choices;
            const bool decided = builder->build(input, params, rule, ctx, tree, choices);
            ctx.report(0.8);
            Array<Box>().swap(input.boxes); // flattening needs only the tree
            Array<uint32_t>().swap(input.prim_ids);
            if (!decided) choose_subtrees(tree, rule, ctx, choices);
            // AACBVH_PARAM_OPTIMIZE_PASSES: part of the build, its time and its built_sah_cost.
            if (params.optimize_passes > 0) optimize_tree(tree, rule, choices, params.optimize_passes, ctx, 0.8, 0.9);
            const ScratchArena::Pause handle_arrays;
            if (straight) {
                make_compact_layouts(tree, rule, choices, result, layouts);
                made = true;
            } else {
                emit_bvh(tree, rule, choices, ctx, result);
            }
        }
        const ScratchArena::Pause layout_arrays;
        if (!made) make_layouts(result, layouts);
    }
    ctx.report(1.0);

    // Success: only now does the handle change.
    bvh_ = std::move(result);
    install(layouts);
    invalid_count_ = invalid_count;
    build_peak_bytes_ = uint64_t(meter.peak());
    built_kind_ = geometry_.kind;
    built_primitive_count_ = geometry_.primitive_count;
    has_topology_ = true;
    valid_ = true;
    {
        std::lock_guard<std::mutex> lock(figures_mutex_);
        figures_known_ = false;     // measured on the first stats call
        built_areas_known_ = false; // the same, until a refit changes the boxes
    }
    build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void BvhObject::make_layouts(const Bvh &tree, Layouts &out) const {
    if (params.layout == AACBVH_LAYOUT_WIDE4) out.wide.build(tree, scheduler_);
    if (params.layout == AACBVH_LAYOUT_WIDE8) {
        out.wide8.build(tree, packets_wanted() ? &geometry_ : nullptr, scheduler_, collapse_rule());
        // The packets hold the vertices, so the binary boxes can be made
        // again from them: keep the shape only (its refit needs no sources).
        if (out.wide8.has_packets() && out.topology.encode(tree, scheduler_)) out.wide8.release_sources();
    }
    if (flat_copy_wanted()) {
        out.triangles.resize(9 * tree.prim_ids.size());
        copy_triangles(tree, out.triangles.data());
    }
}

namespace testing {
std::atomic<bool> straight_layouts{true};
} // namespace testing

bool BvhObject::straight_to_compact(size_t primitives) const {
    return testing::straight_layouts.load(std::memory_order_relaxed) && packets_wanted() &&
           params.max_leaf_size <= CompactTopology::kMaxLeafCount && primitives < (size_t(1) << 31);
}

void BvhObject::make_compact_layouts(BinaryTree &tree, const FlattenRule &rule, SubtreeChoices &choices, Bvh &result,
                                     Layouts &out) const {
    Array<uint8_t> shape;
    prepare_shape(tree, rule, choices, shape, result.prim_ids);
    const ChosenTree view = chosen_view(tree, choices);
    // The collapse writes the shape and the primitive order as it walks
    // (EmittedOrder); the topology takes the shape's array first (moved, so
    // the bytes stay where the collapse writes them).
    const EmittedOrder order{shape.data(), result.prim_ids.data(), tree.prim_ids.data()};
    if (!out.topology.adopt(shape, view)) throw Error(AACBVH_ERROR_INTERNAL, "the tree's shape was not adopted");
    out.wide8.build(
        view, geometry_, order, scheduler_, collapse_rule(),
        [&] {
            Array<uint32_t>().swap(tree.children);
            Array<uint32_t>().swap(tree.prim_ids); // in result.prim_ids now, in leaf order
            SubtreeChoices().swap(choices);
        },
        [&] { Array<Box>().swap(tree.boxes); });
}

void BvhObject::install(Layouts &layouts) noexcept {
    wide_ = std::move(layouts.wide);
    wide8_ = std::move(layouts.wide8);
    triangles_.swap(layouts.triangles);
    topology_ = std::move(layouts.topology);
    if (compact()) Array<Node>().swap(bvh_.nodes);
    drop_made_nodes();
}

void BvhObject::remake_tree(Bvh &out) const {
    out.prim_ids = bvh_.prim_ids;
    remake_nodes(out.nodes);
}

Box BvhObject::packet_leaf_box(const uint32_t *where, uint32_t first, uint32_t count) const {
    Box box = Box::empty();
    for (uint32_t k = 0; k < count; ++k) box.extend(wide8_.packet_triangle_box(where[bvh_.prim_ids[first + k]]));
    return box;
}

void BvhObject::remake_nodes(Array<Node> &out) const {
    Array<uint32_t> where;
    wide8_.index_packets(geometry_.primitive_count, where, scheduler_);
    topology_.decode(out);
    Node *nodes = out.data();
    scheduler_.parallel_for(0, out.size(), 1u << 13, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i)
            if (nodes[i].is_leaf()) nodes[i].box = packet_leaf_box(where.data(), nodes[i].first, nodes[i].count);
    });
    for (size_t i = out.size(); i-- > 0;) {
        Node &node = nodes[i];
        if (!node.is_leaf()) node.box = unite(nodes[node.first].box, nodes[node.first + 1].box);
    }
}

void BvhObject::copy_nodes(size_t first, size_t count, void *out) const {
    if (count == 0) return;
    if (!compact()) {
        std::memcpy(out, bvh_.nodes.data() + first, count * sizeof(Node));
        return;
    }
    std::lock_guard<std::mutex> lock(made_nodes_mutex_);
    if (made_nodes_.empty() && count < topology_.node_count()) remake_nodes(made_nodes_);
    if (!made_nodes_.empty()) {
        std::memcpy(out, made_nodes_.data() + first, count * sizeof(Node));
        return;
    }
    Array<Node> nodes;
    remake_nodes(nodes);
    std::memcpy(out, nodes.data() + first, count * sizeof(Node));
}

void BvhObject::drop_made_nodes() noexcept {
    std::lock_guard<std::mutex> lock(made_nodes_mutex_);
    Array<Node>().swap(made_nodes_);
}

TreeFigures BvhObject::compact_figures() const {
    Array<uint32_t> where;
    wide8_.index_packets(geometry_.primitive_count, where, scheduler_);
    return topology_.walk([&](uint32_t first, uint32_t count) { return packet_leaf_box(where.data(), first, count); },
                          scheduler_);
}

void BvhObject::expand() {
    Bvh full;
    remake_tree(full);
    bvh_.nodes.swap(full.nodes);
    topology_.clear();
    wide8_.clear();
    drop_made_nodes();
}

bool BvhObject::packets_wanted() const {
    return params.layout == AACBVH_LAYOUT_WIDE8 && geometry_.kind == GeometryKind::Triangles &&
           params.triangle_storage == AACBVH_TRIANGLES_COPIED;
}

CollapseRule BvhObject::collapse_rule() const {
    return params.builder == AACBVH_BUILDER_AAC_FAST ? CollapseRule::LargestFirst : CollapseRule::Planned;
}

bool BvhObject::flat_copy_wanted() const {
    return params.layout != AACBVH_LAYOUT_WIDE8 && geometry_.kind == GeometryKind::Triangles &&
           params.triangle_storage == AACBVH_TRIANGLES_COPIED;
}

void BvhObject::refit() {
    require_idle();
    if (!has_topology_) throw Error(AACBVH_ERROR_INVALID_OPERATION, "refit needs a built tree: call aacbvh_bvh_build first");
    if (geometry_.kind != built_kind_ || geometry_.primitive_count != built_primitive_count_)
        throw Error(AACBVH_ERROR_INVALID_OPERATION,
                    "refit needs the primitive count of the last build (" + std::to_string(built_primitive_count_) +
                        "), got " + std::to_string(geometry_.primitive_count) + ": build instead");
    // Check first so that a bad coordinate leaves the tree as it was.
    const size_t bad = first_problem_in_tree();
    if (bad != SIZE_MAX)
        throw Error(AACBVH_ERROR_INVALID_GEOMETRY, std::string(geometry_.kind == GeometryKind::Boxes ? "box " : "triangle ") +
                                                       std::to_string(bad) + " " + primitive_problem(geometry_, bad));
    // Only the binary tree's shape is kept: the 8-wide tree refits from its
    // packets, and a walk over the shape gives the statistics their areas.
    if (compact() && params.layout == AACBVH_LAYOUT_WIDE8 && packets_wanted()) {
        refit_compact();
        return;
    }
    if (compact()) expand(); // another layout: it is made from the binary nodes
    // The wide tree is made before the refit can change anything (the
    // topology is the same), then takes the refitted boxes.
    if (params.layout != AACBVH_LAYOUT_WIDE4)
        wide_.clear();
    else if (!wide_.built())
        wide_.build(bvh_, scheduler_);
    // The 8-wide tree likewise; its packets are copied from the geometry
    // being refitted to, which has passed the checks above.
    if (params.layout != AACBVH_LAYOUT_WIDE8)
        wide8_.clear();
    else if (!wide8_.built() || wide8_.has_packets() != packets_wanted())
        wide8_.build(bvh_, packets_wanted() ? &geometry_ : nullptr, scheduler_, collapse_rule());
    // The triangle copy (AACBVH_TRIANGLES_COPIED) is allocated before the
    // refit, so that running out of memory leaves the tree as it was, and
    // filled in place after it.
    const bool copied = flat_copy_wanted();
    if (!copied)
        Array<float>().swap(triangles_);
    else if (triangles_.size() != 9 * bvh_.prim_ids.size())
        triangles_.resize(9 * bvh_.prim_ids.size());
    {
        // The built tree's area sums, kept before the first refit changes
        // them: built_sah_cost is then given for the costs in force, like
        // sah_cost, so their ratio (the drift) is 1 when nothing moved.
        std::lock_guard<std::mutex> lock(figures_mutex_);
        if (!built_areas_known_) {
            built_areas_ = figures_known_ ? figures_.areas : sum_areas(bvh_, scheduler_);
            built_areas_known_ = true;
        }
    }
    refit_tree(bvh_, geometry_, scheduler_);
    if (copied) copy_triangles(bvh_, triangles_.data());
    {
        // Leaf count and depth stay (same topology); the areas are summed now,
        // so that stats in a refit loop cost nothing more.
        std::lock_guard<std::mutex> lock(figures_mutex_);
        if (figures_known_) figures_.areas = sum_areas(bvh_, scheduler_);
    }
    if (wide_.built()) wide_.refit(bvh_, scheduler_);
    if (wide8_.built()) wide8_.refit(bvh_, geometry_, scheduler_);
    valid_ = true;
}

size_t BvhObject::first_problem_in_tree() const {
    // A tree holds each primitive at most once, so one of as many primitives
    // as the geometry holds them all: they are checked in the caller's
    // order, whose index and vertex reads run forward, instead of the
    // leaves' (random reads: the check took longer than the refit itself,
    // docs/PERFORMANCE.md row 209). A tree that left invalid primitives out
    // checks its own.
    const uint32_t *prims = bvh_.prim_ids.data();
    const bool all = bvh_.prim_ids.size() == geometry_.primitive_count;
    return scheduler_.parallel_reduce(
        size_t(0), bvh_.prim_ids.size(), size_t(1) << 14, SIZE_MAX,
        [&](size_t b, size_t e) {
            size_t first = SIZE_MAX;
            for (size_t i = b; i < e; ++i) {
                const size_t p = all ? i : prims[i];
                if (primitive_problem(geometry_, p)) {
                    first = std::min(first, p);
                    if (all) break; // the rest of the chunk comes later
                }
            }
            return first;
        },
        [](size_t a, size_t b) { return std::min(a, b); });
}

void BvhObject::refit_compact() {
    // What may allocate comes first, so that running out of memory leaves
    // the tree as it was: the built tree's areas (see refit()), then, when
    // the statistics were asked for, the new ones (the walk reads the new
    // geometry and changes nothing).
    {
        std::lock_guard<std::mutex> lock(figures_mutex_);
        if (!built_areas_known_) {
            built_areas_ = figures_known_ ? figures_.areas : compact_figures().areas;
            built_areas_known_ = true;
        }
    }
    bool measure;
    {
        std::lock_guard<std::mutex> lock(figures_mutex_);
        measure = figures_known_;
    }
    TreeFigures f;
    if (measure) {
        const uint32_t *ids = bvh_.prim_ids.data();
        const size_t slots = bvh_.prim_ids.size();
        const bool triangles = geometry_.kind == GeometryKind::Triangles;
        f = topology_.walk(
            [&](uint32_t first, uint32_t count) {
                // The walk's branches would stall on each leaf's reads: ask
                // for the triangles a few leaves ahead (index, then vertices).
                if (triangles && first + count + 32 <= slots)
                    for (uint32_t k = 0; k < count; ++k) {
                        geometry_.prefetch_indices(ids[first + 32 + k]);
                        geometry_.prefetch_vertices(ids[first + 16 + k]);
                    }
                Box box = Box::empty();
                for (uint32_t k = 0; k < count; ++k) box.extend(geometry_.primitive_box(ids[first + k]));
                return box;
            },
            scheduler_);
    }
    wide8_.refit_from_packets(geometry_, scheduler_);
    drop_made_nodes(); // their boxes are the old ones
    {
        std::lock_guard<std::mutex> lock(figures_mutex_);
        if (measure) figures_ = f;
    }
    valid_ = true;
}

void BvhObject::optimize(uint32_t passes) {
    require_idle();
    require_tree();
    if (passes > kMaxOptimizePasses)
        reject("passes must be at most " + std::to_string(kMaxOptimizePasses) + ", got " + std::to_string(passes));
    struct Building {
        bool &flag;
        explicit Building(bool &f) : flag(f) { flag = true; }
        ~Building() { flag = false; }
    } building(building_);
    const KeptMemory kept(kept_blocks_, params.keep_build_memory);
    ScratchArena scratch; // as in build()
    const ScratchArena::Scope scratch_scope(&scratch);
    const BuildPageMapping page_mapping(scheduler_);
    BuildContext ctx(scheduler_, progress_, progress_user_);
    ctx.report(0.0);
    if (passes == 0 || bvh_.prim_ids.size() < 3) { // fewer than three primitives: one topology
        ctx.report(1.0);
        return;
    }
    // Like a build, into temporaries: the handle changes only on success.
    // The SAH as stats report it, measured before the tree changes.
    const double before = figures().areas.sah_cost(params.traversal_cost, params.intersection_cost);
    Bvh result;
    {
        BinaryTree tree;
        {
            // The current shape: where the handle keeps it compact, decoded
            // without boxes (unflatten() boxes the primitives itself).
            Array<Node> decoded;
            if (compact()) topology_.decode(decoded);
            const Array<Node> &shape = compact() ? decoded : bvh_.nodes;
            unflatten(shape.data(), shape.size(), bvh_.prim_ids.data(), bvh_.prim_ids.size(), geometry_, ctx, tree);
        }
        ctx.report(0.05);
        const FlattenRule rule{params.max_leaf_size, params.traversal_cost, params.intersection_cost, false,
                               extent_scale_of(tree.boxes[tree.root])};
        SubtreeChoices choices;
        choose_subtrees(tree, rule, ctx, choices);
        optimize_tree(tree, rule, choices, passes, ctx, 0.1, 0.85);
        const ScratchArena::Pause handle_arrays;
        emit_bvh(tree, rule, choices, ctx, result);
    }
    // The SAH as stats report it never rises: a tree that would cost more
    // (rounding, or leaves over a max_leaf_size lowered since the build) is
    // not taken.
    const double after = sum_areas(result, scheduler_).sah_cost(params.traversal_cost, params.intersection_cost);
    if (!(after < before)) {
        ctx.report(1.0);
        return;
    }
    Layouts layouts;
    {
        const ScratchArena::Pause handle_arrays;
        make_layouts(result, layouts);
    }
    ctx.report(1.0);

    bvh_ = std::move(result);
    install(layouts);
    std::lock_guard<std::mutex> lock(figures_mutex_);
    figures_known_ = false;     // a new topology: measured on the next stats call
    built_areas_known_ = false; // built_sah_cost is now this tree's, as after a build
}

void BvhObject::require_tree() const {
    if (valid_) return;
    if (!has_topology_) throw Error(AACBVH_ERROR_INVALID_OPERATION, "no tree: call aacbvh_bvh_build first");
    throw Error(AACBVH_ERROR_INVALID_OPERATION, "the geometry changed since the last build: build or refit first");
}

TreeFigures BvhObject::figures() const {
    std::lock_guard<std::mutex> lock(figures_mutex_);
    if (!figures_known_) {
        figures_ = compact() ? compact_figures() : measure_tree(bvh_, scheduler_);
        figures_known_ = true;
    }
    return figures_;
}

void BvhObject::stats(aacbvh_stats &out) const {
    require_tree();
    const TreeFigures f = figures();
    out.max_depth = f.max_depth;
    out.node_count = node_count();
    out.leaf_count = f.leaf_count;
    out.primitive_count = bvh_.prim_ids.size();
    out.sah_cost = f.areas.sah_cost(params.traversal_cost, params.intersection_cost);
    out.kept_build_bytes = kept_build_bytes();
    size_t made_bytes;
    {
        std::lock_guard<std::mutex> lock(made_nodes_mutex_);
        made_bytes = held_bytes(made_nodes_);
    }
    out.memory_bytes = sizeof(*this) + bvh_.memory_bytes() + topology_.memory_bytes() + wide_.memory_bytes() +
                       wide8_.memory_bytes() + held_bytes(triangles_) + made_bytes + out.kept_build_bytes;
    out.invalid_primitive_count = invalid_count_;
    out.build_peak_bytes = build_peak_bytes_;
    AreaSums built;
    {
        std::lock_guard<std::mutex> lock(figures_mutex_);
        built = built_areas_known_ ? built_areas_ : f.areas; // no refit since the build: the same tree
    }
    out.built_sah_cost = built.sah_cost(params.traversal_cost, params.intersection_cost);
    out.build_seconds = build_seconds_;
}

void BvhObject::intersect(const aacbvh_ray *rays, aacbvh_hit *hits, size_t count) const {
    require_tree();
    const float *triangles = triangle_copy();
    if (wide8_.built()) {
        const Wide8Kernel &kernel = wide8_kernel();
        scheduler_.parallel_for(0, count, 256, [&](size_t b, size_t e) {
            kernel.intersect_batch(wide8_, bvh_, geometry_, rays + b, hits + b, e - b);
        });
        return;
    }
    scheduler_.parallel_for(0, count, 1024, [&](size_t b, size_t e) {
        if (wide_.built())
            for (size_t i = b; i < e; ++i) intersect_ray_wide(wide_, bvh_, geometry_, rays[i], hits[i], triangles);
        else
            for (size_t i = b; i < e; ++i) intersect_ray(bvh_, geometry_, rays[i], hits[i], nullptr, triangles);
    });
}

void BvhObject::occluded(const aacbvh_ray *rays, uint8_t *out, size_t count) const {
    require_tree();
    const float *triangles = triangle_copy();
    if (wide8_.built()) {
        const Wide8Kernel &kernel = wide8_kernel();
        scheduler_.parallel_for(0, count, 256, [&](size_t b, size_t e) {
            kernel.occluded_batch(wide8_, bvh_, geometry_, rays + b, out + b, e - b);
        });
        return;
    }
    scheduler_.parallel_for(0, count, 1024, [&](size_t b, size_t e) {
        if (wide_.built())
            for (size_t i = b; i < e; ++i) out[i] = occluded_ray_wide(wide_, bvh_, geometry_, rays[i], triangles) ? 1 : 0;
        else
            for (size_t i = b; i < e; ++i) out[i] = occluded_ray(bvh_, geometry_, rays[i], nullptr, triangles) ? 1 : 0;
    });
}

} // namespace aacbvh
