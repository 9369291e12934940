# aacbvh-bench: the evaluation benchmark (ray cost, build times, Embree beside
# us). Included from examples/CMakeLists.txt. Embree 3 is optional and used by
# this benchmark only; the library and its tests never depend on it.
set(_bench_dir ${CMAKE_CURRENT_LIST_DIR})

option(AACBVH_BENCH_EMBREE "Compare with Embree 3 in the benchmark programs when it is found" ON)
if(AACBVH_BENCH_EMBREE)
  find_path(EMBREE3_INCLUDE_DIR embree3/rtcore.h)
  find_library(EMBREE3_LIBRARY NAMES embree3)
endif()
# Sanitizer builds leave Embree out: it is not instrumented, so ThreadSanitizer
# reports races inside it that are not ours, and its timings mean nothing there.
set(_bench_embree OFF)
if(AACBVH_BENCH_EMBREE AND EMBREE3_INCLUDE_DIR AND EMBREE3_LIBRARY AND NOT AACBVH_SANITIZE)
  set(_bench_embree ON)
endif()
# Compiles TARGET with Embree 3 beside us (AACBVH_BENCH_HAVE_EMBREE) where
# it is used; elsewhere its embree_bench.cpp calls report it missing.
function(bench_use_embree target)
  if(_bench_embree)
    target_compile_definitions(${target} PRIVATE AACBVH_BENCH_HAVE_EMBREE=1)
    target_include_directories(${target} PRIVATE ${EMBREE3_INCLUDE_DIR})
    target_link_libraries(${target} PRIVATE ${EMBREE3_LIBRARY})
  endif()
endfunction()

add_library(aacbvh_bench_core STATIC
  ${_bench_dir}/ray_cost.cpp
  ${_bench_dir}/rays.cpp
  ${_bench_dir}/report.cpp)
target_include_directories(aacbvh_bench_core PUBLIC ${_bench_dir})
target_compile_options(aacbvh_bench_core PRIVATE -Wall -Wextra)
target_link_libraries(aacbvh_bench_core PUBLIC aacbvh aacbvh_scene)

add_executable(aacbvh-bench
  ${_bench_dir}/bench_main.cpp
  ${_bench_dir}/embree_bench.cpp)
target_compile_options(aacbvh-bench PRIVATE -Wall -Wextra)
target_link_libraries(aacbvh-bench PRIVATE aacbvh_bench_core aacbvh_scene Threads::Threads)
target_compile_definitions(aacbvh-bench PRIVATE AACBVH_SCENES_DIR="${AACBVH_SCENES_DIR}")
bench_use_embree(aacbvh-bench)
if(_bench_embree)
  message(STATUS "aacbvh-bench: comparing with Embree 3 (${EMBREE3_LIBRARY})")
else()
  message(STATUS "aacbvh-bench: Embree 3 not found or disabled, benchmark without it")
endif()

# aacbvh-hit-accuracy: how exact the hit distances are, ours against Embree's
# (relative error of t against the double-precision ray-plane distance), with
# Embree compiled in under the same conditions as aacbvh-bench.
add_executable(aacbvh-hit-accuracy ${_bench_dir}/hit_accuracy.cpp)
target_compile_options(aacbvh-hit-accuracy PRIVATE -Wall -Wextra)
target_link_libraries(aacbvh-hit-accuracy PRIVATE aacbvh_bench_core aacbvh_scene)
target_compile_definitions(aacbvh-hit-accuracy PRIVATE AACBVH_SCENES_DIR="${AACBVH_SCENES_DIR}")
bench_use_embree(aacbvh-hit-accuracy)

# aacbvh-batch-threads: Mrays/s of whole ray batches at each context thread
# count (the rays issue: a batch uses every thread), answers compared across
# the counts.
# With Embree compiled in (as for aacbvh-bench), --embree puts Embree's scene
# beside us on the same rays.
add_executable(aacbvh-batch-threads ${_bench_dir}/batch_threads.cpp ${_bench_dir}/embree_bench.cpp)
target_compile_options(aacbvh-batch-threads PRIVATE -Wall -Wextra)
target_link_libraries(aacbvh-batch-threads PRIVATE aacbvh_bench_core aacbvh_scene)
target_compile_definitions(aacbvh-batch-threads PRIVATE AACBVH_SCENES_DIR="${AACBVH_SCENES_DIR}")
bench_use_embree(aacbvh-batch-threads)

# aacbvh-build-phases: a build's time per phase (input, sort, clustering,
# layouts) at each context thread count, stamped by a progress callback.
add_executable(aacbvh-build-phases ${_bench_dir}/build_phases.cpp)
target_compile_options(aacbvh-build-phases PRIVATE -Wall -Wextra)
target_link_libraries(aacbvh-build-phases PRIVATE aacbvh_bench_core aacbvh_scene)
target_compile_definitions(aacbvh-build-phases PRIVATE AACBVH_SCENES_DIR="${AACBVH_SCENES_DIR}")

if(AACBVH_BUILD_TESTS)
  # A test that runs TARGET with ARGS (one string, split as a shell would)
  # and passes when it exits 0 and its standard output matches the regular
  # expression EXPECT (run_expect.cmake: PASS_REGULAR_EXPRESSION alone would
  # ignore the exit status). Five minutes at most.
  function(bench_expect_test name target args expect)
    add_test(NAME ${name}
      COMMAND ${CMAKE_COMMAND} -DPROGRAM=$<TARGET_FILE:${target}> "-DARGS=${args}" "-DEXPECT=${expect}"
              -P ${_bench_dir}/run_expect.cmake)
    set_tests_properties(${name} PROPERTIES TIMEOUT 300)
  endfunction()

  # The ray-cost counter on a hand-built tree whose counts are known exactly.
  add_executable(test_ray_cost ${_bench_dir}/test_ray_cost.cpp)
  target_compile_options(test_ray_cost PRIVATE -Wall -Wextra)
  target_link_libraries(test_ray_cost PRIVATE aacbvh_bench_core)
  add_test(NAME bench_ray_cost COMMAND test_ray_cost)

  # The --scenes list: "shared" expanded to the scenes directory's OBJ files.
  add_executable(test_scene_specs ${_bench_dir}/test_scene_specs.cpp)
  target_compile_options(test_scene_specs PRIVATE -Wall -Wextra)
  target_link_libraries(test_scene_specs PRIVATE aacbvh_bench_core)
  add_test(NAME bench_scene_specs COMMAND test_scene_specs)

  # The report: Pareto fronts, JSON written and read back, the plot's panels.
  add_executable(test_report ${_bench_dir}/test_report.cpp)
  target_compile_options(test_report PRIVATE -Wall -Wextra)
  target_link_libraries(test_report PRIVATE aacbvh_bench_core)
  add_test(NAME bench_report COMMAND test_report)

  # --replot on the committed results, as docs/evaluation.svg is made: the
  # outputs pass --self-check, the JSON comes back unchanged, and the committed
  # plot is the one the current code draws (after changing the plot, run
  # aacbvh-bench --replot docs/evaluation.json --svg docs/evaluation.svg).
  set(_replot ${CMAKE_CURRENT_BINARY_DIR}/bench_replot)
  add_test(NAME bench_replot
    COMMAND aacbvh-bench --replot ${PROJECT_SOURCE_DIR}/docs/evaluation.json --self-check
            --json ${_replot}.json --svg ${_replot}.svg --markdown ${_replot}.md --csv ${_replot}.csv)
  set_tests_properties(bench_replot PROPERTIES FIXTURES_SETUP bench_replot)
  add_test(NAME bench_replot_json_unchanged
    COMMAND ${CMAKE_COMMAND} -E compare_files ${PROJECT_SOURCE_DIR}/docs/evaluation.json ${_replot}.json)
  add_test(NAME bench_replot_svg_current
    COMMAND ${CMAKE_COMMAND} -E compare_files ${PROJECT_SOURCE_DIR}/docs/evaluation.svg ${_replot}.svg)
  set_tests_properties(bench_replot_json_unchanged bench_replot_svg_current PROPERTIES
    FIXTURES_REQUIRED bench_replot)

  # Smoke test: a small generated scene, one run, every output written and read
  # back (--self-check); no timing is judged.
  add_test(NAME bench_smoke
    COMMAND aacbvh-bench --scenes procedural-small --runs 1 --rays 32 --views 6 --view-rays 16x12 --threads 1,2
            --self-check
            --csv ${CMAKE_CURRENT_BINARY_DIR}/bench_smoke.csv
            --json ${CMAKE_CURRENT_BINARY_DIR}/bench_smoke.json
            --svg ${CMAKE_CURRENT_BINARY_DIR}/bench_smoke.svg
            --markdown ${CMAKE_CURRENT_BINARY_DIR}/bench_smoke.md)
  set_tests_properties(bench_smoke PROPERTIES TIMEOUT 300)

  # The in-scene views' table: the console prints it with every column, one
  # line per builder and ray kind (--self-check checks its figures: worst views
  # no better than the mean, sweep SAH exactly 1 against itself), and the CSV
  # carries the view and overlap columns.
  bench_expect_test(bench_views_table aacbvh-bench
    "--scenes procedural-small --runs 1 --rays 8 --views 3 --view-rays 8 --builders sweep-sah,aac-hq,aac-fast --no-embree --self-check --csv ${CMAKE_CURRENT_BINARY_DIR}/bench_views.csv"
    "in-scene views: 3 of 8x8 primary rays.*builder +rays +SAH +overlap A/V +boxes +tris +rel\\. cost +Mrays/s +rel\\. time\n+Sweep SAH +primary +[0-9.]+ +[0-9.]+/[0-9.]+ +[0-9.]+/[0-9.]+ +[0-9.]+/[0-9.]+ +1\\.00/1\\.00 .*AAC-Fast +primary")

  # Smoke test of aacbvh-batch-threads: a small generated scene at one, two
  # and three threads; it exits 1 when a thread count's answers differ from
  # one thread's, and must print a speedup column.
  bench_expect_test(bench_batch_threads_smoke aacbvh-batch-threads
    "--scenes procedural-small --rays 48 --threads 1,2,3 --runs 1"
    "procedural-small +diffuse +[0-9]+ +[0-9.]+ +[0-9.]+ \\([0-9.]+x\\) +[0-9.]+ \\([0-9.]+x\\)\n")
  # With Embree compiled in, --embree traces the same rays through its scene
  # and prints its Mrays/s and our ratio to it on every ray kind.
  if(_bench_embree)
    bench_expect_test(bench_batch_threads_embree aacbvh-batch-threads
      "--scenes procedural-small --rays 48 --threads 1 --runs 1 --embree"
      "Embree 3\\.[0-9.]+, 1 thr.*procedural-small +primary +[0-9]+ +[0-9.]+ +[0-9.]+ \\([0-9.]+x\\)\n.*procedural-small +shadow +[0-9]+ +[0-9.]+ +[0-9.]+ \\([0-9.]+x\\)\n.*procedural-small +diffuse +[0-9]+ +[0-9.]+ +[0-9.]+ \\([0-9.]+x\\)\n")
  endif()

  # Smoke tests of aacbvh-build-phases: a small generated scene at one, two
  # and three threads, fresh handles and one kept-memory handle; it exits 1
  # when a thread count's tree differs from the first count's, and must print
  # the phase columns with their speedups.
  bench_expect_test(bench_build_phases_smoke aacbvh-build-phases
    "--scenes procedural-small --threads 1,2,3 --runs 2"
    "procedural-small +aac-fast +3( +[0-9.]+ +[0-9.]+x| +[0-9.]+ +)( +[0-9.]+ +[0-9.]+x| +[0-9.]+ +)( +[0-9.]+ +[0-9.]+x| +[0-9.]+ +)( +[0-9.]+ +[0-9.]+x| +[0-9.]+ +) +[0-9.]+ +[0-9.]+x +[0-9.]+-[0-9.]+ *\n")
  bench_expect_test(bench_build_phases_kept_smoke aacbvh-build-phases
    "--scenes procedural-small --builders aac-hq,ploc --threads 1,2 --runs 2 --keep-build-memory"
    "one handle rebuilt with kept build memory.*procedural-small +ploc +2 ")

  # Smoke test of aacbvh-hit-accuracy: a small generated scene; it must exit 0
  # and print the accuracy table's header.
  bench_expect_test(bench_hit_accuracy_smoke aacbvh-hit-accuracy
    "--scenes procedural-small --size 32 --runs 1 --markdown ${CMAKE_CURRENT_BINARY_DIR}/bench_hit_accuracy_smoke.md"
    "\\| scene \\| rays \\| library \\| hits \\| measured \\| max rel\\. error \\|")
endif()
