// Every builder the library offers, in one table: its aacbvh_builder value,
// the short name the C API reports (aacbvh_builder_name), what it is, and how
// it is run. Parameter checks, the build and the names that programs show
// (demo, benchmark, Python binding) all read this table, so a new builder is
// one entry here plus its file under build/.
#pragma once

#include <cstddef>
#include <cstdint>

#include "aacbvh/aacbvh.h"
#include "build/aac/aac_builder.h"
#include "build/build_input.h"

namespace aacbvh {

struct Params;

struct BuilderInfo {
    aacbvh_builder value;
    const char *name;    ///< short, lower case, with dashes: "aac-hq"
    const char *summary; ///< one line for help texts
    /// Selecting the builder sets these AAC parameters (the paper's presets);
    /// nullptr leaves them as they are.
    AacConfig (*preset)();
    /// Builds `input` into `tree`. Builders that decide the flattening while
    /// they build (AAC) fill `choices` and return true; the others return
    /// false and leave it to build/flatten.h.
    bool (*build)(BuildInput &input, const Params &params, const FlattenRule &rule, BuildContext &ctx,
                  BinaryTree &tree, SubtreeChoices &choices);
    /// What the input's box array leaves room for (build/build_input.h):
    /// the AAC builders take it over as their tree's boxes.
    InputRoom input_room = InputRoom::None;
};

/// The table, in aacbvh_builder order; `count` gets its length.
const BuilderInfo *builder_table(size_t &count);
/// The entry of `value`, or nullptr when it is no aacbvh_builder.
const BuilderInfo *find_builder(int64_t value);

} // namespace aacbvh
