# Packaging and ABI checks that are not cmocka programs; included from
# tests/CMakeLists.txt.

# ---- exported symbols, symbol versions and SONAME ----
add_test(NAME exported_symbols
  COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/check_symbols.sh
          $<TARGET_FILE:aacbvh>
          ${CMAKE_CURRENT_SOURCE_DIR}/exported_symbols.txt
          ${PROJECT_SOURCE_DIR}/include/aacbvh/aacbvh.h
          libaacbvh.so.${PROJECT_VERSION_MAJOR})

# ---- the public header compiles as strict C99 and C++ ----
# Run as tests rather than build steps, so a header problem shows up as a named
# failure; the compiler is the project's, the flags are fixed here.
set(_aacbvh_header_dir ${CMAKE_CURRENT_BINARY_DIR}/header_checks)
file(MAKE_DIRECTORY ${_aacbvh_header_dir})
add_test(NAME header_c99
  COMMAND ${CMAKE_C_COMPILER} -std=c99 -pedantic -Wall -Wextra -Wstrict-prototypes -Werror
          -I${PROJECT_SOURCE_DIR}/include -c ${CMAKE_CURRENT_SOURCE_DIR}/header_c99.c
          -o ${_aacbvh_header_dir}/header_c99.o)
foreach(_std 11 17)
  add_test(NAME header_cxx${_std}
    COMMAND ${CMAKE_CXX_COMPILER} -std=c++${_std} -pedantic -Wall -Wextra -Werror
            -I${PROJECT_SOURCE_DIR}/include -c ${CMAKE_CURRENT_SOURCE_DIR}/header_cxx.cpp
            -o ${_aacbvh_header_dir}/header_cxx${_std}.o)
endforeach()

# ---- examples run, so the documentation cannot rot ----
if(AACBVH_BUILD_EXAMPLES)
  add_test(NAME example_c_minimal COMMAND c-minimal)
  add_test(NAME readme_example
    COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/check_readme_example.sh
            ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/examples/c-minimal.c)
  set_tests_properties(example_c_minimal PROPERTIES
    PASS_REGULAR_EXPRESSION "hit triangle 1 at t = 1 ")
  # Every builder on a small generated scene, with the cross-builder hit check;
  # the reference (sweep-sah) row comes first with ratios of 1.00, the legend
  # follows the table, and "done" only when every check passed.
  add_test(NAME example_demo_small
    COMMAND aacbvh-demo --small --runs 2 --builders all --threads 2)
  set_tests_properties(example_demo_small PROPERTIES TIMEOUT 300
    PASS_REGULAR_EXPRESSION "ms/sweep +SAH cost +SAH/sweep[^\n]*\n[^\n]* sweep-sah +2 +[0-9.]+ +[0-9.]+ +[0-9.]+ +1\\.00 +[0-9.]+ +1\\.00 .*\ncolumns:\n.*\ndone in")
  # The game-engine loop, a few frames with a low threshold so that both the
  # refit and the rebuild paths run; it checks its refitted tree against a fresh build.
  add_test(NAME example_animated
    COMMAND animated --frames 12 --triangles 20000 --threads 2 --threshold 1.05)
  set_tests_properties(example_animated PROPERTIES
    PASS_REGULAR_EXPRESSION "refitted tree and fresh build agree" TIMEOUT 300)

  # The ray tracer writes a small PNG; check_png.py then reads it back with
  # Python's zlib alone (signature, IHDR, CRCs, Adler-32, filters) and checks
  # that it shows something. A missing OBJ file falls back to the generated scene.
  find_package(Python3 COMPONENTS Interpreter)
  set(_aacbvh_renders procedural)
  if(EXISTS "${AACBVH_SCENES_DIR}/bunny.obj")
    list(APPEND _aacbvh_renders bunny)
  endif()
  foreach(_scene IN LISTS _aacbvh_renders)
    set(_png ${CMAKE_CURRENT_BINARY_DIR}/render_${_scene}.png)
    if(_scene STREQUAL "procedural")
      set(_obj ${CMAKE_CURRENT_BINARY_DIR}/no-such-scene.obj)
      set(_expect "generated scene, [0-9]+ triangles.*wrote .*: 64x48")
    else()
      set(_obj "${AACBVH_SCENES_DIR}/${_scene}.obj")
      set(_expect "${_scene}.obj, [0-9]+ triangles.*wrote .*: 64x48")
    endif()
    add_test(NAME example_render_${_scene}
      COMMAND render --width 64 --height 48 --output ${_png} ${_obj})
    set_tests_properties(example_render_${_scene} PROPERTIES
      PASS_REGULAR_EXPRESSION "${_expect}" FIXTURES_SETUP render_${_scene} TIMEOUT 300)
    if(Python3_Interpreter_FOUND)
      add_test(NAME example_render_${_scene}_png
        COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/check_png.py ${_png} 64 48)
    else()
      add_test(NAME example_render_${_scene}_png COMMAND ${CMAKE_COMMAND} -E echo "SKIPPED: python3 not found")
      set_tests_properties(example_render_${_scene}_png PROPERTIES SKIP_REGULAR_EXPRESSION "SKIPPED:")
    endif()
    set_tests_properties(example_render_${_scene}_png PROPERTIES FIXTURES_REQUIRED render_${_scene})
  endforeach()
endif()

# ---- install, then use through pkg-config and find_package ----
# Skipped in sanitizer builds: the installed library would need the sanitizer
# runtime loaded first in every program that links it.
if(NOT AACBVH_SANITIZE)
  add_test(NAME install_relocated
    COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/install_test.sh relocated
            ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR} ${CMAKE_COMMAND} ${CMAKE_C_COMPILER})
  # A second, library-only build configured with an absolute libdir.
  add_test(NAME install_absolute_libdir
    COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/install_test.sh absolute
            ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR} ${CMAKE_COMMAND} ${CMAKE_C_COMPILER})
  # With only a compiler and CMake: cmocka and tinyobjloader hidden, the plain
  # configure, build and install work (library and examples), asking for the
  # tests fails with what to install, and inside another project libaacbvh's
  # tests stay out.
  add_test(NAME build_without_test_deps
    COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/minimal_build_test.sh
            ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR} ${CMAKE_COMMAND}
            ${CMAKE_C_COMPILER} ${CMAKE_CXX_COMPILER})
  # One at a time (each builds or installs with every core), and first: a
  # fresh build directory has no timings for ctest to order by, and these
  # three, started after the unit tests, ran alone at the end of the stage.
  # COST (about their seconds on the 2-core CI machine) starts them first.
  set_tests_properties(install_relocated install_absolute_libdir build_without_test_deps PROPERTIES
    TIMEOUT 900 RESOURCE_LOCK aacbvh_install)
  set_tests_properties(build_without_test_deps PROPERTIES COST 50)
  set_tests_properties(install_absolute_libdir PROPERTIES COST 30)
  set_tests_properties(install_relocated PROPERTIES COST 5)
endif()

# ---- ABI against the committed baseline (libabigail), Python ctypes binding ----
add_subdirectory(${CMAKE_CURRENT_SOURCE_DIR}/abi ${CMAKE_CURRENT_BINARY_DIR}/abi)
add_subdirectory(${CMAKE_CURRENT_SOURCE_DIR}/python ${CMAKE_CURRENT_BINARY_DIR}/python)
