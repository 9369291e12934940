// The greedy loop of the SIMD small combines, included by each kernel's file
// (combine_small_avx2.cpp, combine_small_avx512.cpp) inside its own target
// region, after it has defined its register state S:
//   int32_t nn[];  each live slot's nearest neighbour (nd[] its distance);
//   void set(uint32_t slot, const Box &);  the initial fill;
//   void unite_into(Box &out, uint32_t a, uint32_t b) const;  the union of
//     slots a and b (unite()'s bits) written to out;
//   static uint32_t padded(uint32_t count);  the lanes its loops read;
//   void retire(uint32_t slot);  a lane past the live slots (kFarBox);
//   void move_slots(uint32_t a, const Box &, uint32_t b, uint32_t last);  after
//     a merge of a and b: slot last moved to b (unless b is last), last
//     retired, a set to the merged box;
//   void all_nearest(uint32_t count);  every slot's nearest other slot (the
//     lowest of equals) into nn, its distance into nd;
//   uint32_t closest_pair(uint32_t live) const;  the lowest slot whose nd is
//     the smallest;
//   uint32_t after_merge(uint32_t a, uint32_t b, uint32_t last, uint32_t live);
//     after merging a and b into slot a and moving slot last to b: slot a's
//     nearest (its row d(a, .)), the others' nearest-neighbour bookkeeping,
//     then closest_pair(live) for the next merge.
// The merges are those of the scalar loop (build/aac/cluster_combine.cpp).
// No lambdas here: a target region does not reach into them.

/// The inner-node choice of cluster `id` (a leaf's, or its merge's).
inline SubtreeChoice cluster_choice(const BinaryTree &tree, const FlattenRule &rule, ChoiceTable choices,
                                    uint32_t id) {
    const uint32_t n = tree.leaf_count();
    return id < n ? rule.leaf(tree.boxes[id]) : choices.get(id - n);
}

template <class S>
uint32_t greedy_loop(S &s, BinaryTree &tree, uint32_t *ids, uint32_t *free_ids, uint32_t count, uint32_t target,
                     const FlattenRule &rule, ChoiceTable choices) {
    const uint32_t n = tree.leaf_count();
    for (uint32_t i = 0; i < count; ++i) s.set(i, tree.boxes[ids[i]]);
    for (uint32_t i = count; i < S::padded(count); ++i) s.retire(i);
    s.all_nearest(count);

    uint32_t live = count, used = 0;
    uint32_t next = s.closest_pair(live);
    while (live > target) {
        uint32_t a = next;
        uint32_t b = uint32_t(s.nn[a]);
        if (a > b) std::swap(a, b);

        const uint32_t node = free_ids[used++];
        Box &merged = tree.boxes[node];
        s.unite_into(merged, a, b);
        tree.set_children(node, ids[a], ids[b]);
        choices.set(node - n, rule.inner(merged, cluster_choice(tree, rule, choices, ids[a]),
                                         cluster_choice(tree, rule, choices, ids[b])));

        const uint32_t last = live - 1;
        s.move_slots(a, merged, b, last);
        if (b != last) ids[b] = ids[last];
        live = last;
        ids[a] = node;
        next = s.after_merge(a, b, last, live);
    }
    for (uint32_t i = 0; i < live; ++i) free_ids[i] = free_ids[used + i];
    return live;
}
