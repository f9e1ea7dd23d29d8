# bareskin_library(NAME SOURCES ... LINK ...): one library per module, includes from the repository root
# ("core/mesh.h"), warnings on.
function(bareskin_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_compile_options(${name} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-unused-parameter>)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
endfunction()

# bareskin_test(NAME SOURCES ... LINK ... LABELS ... FIXTURES ...): a GoogleTest binary registered with CTest.
function(bareskin_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINK;LABELS;FIXTURES" ${ARGN})
  if(NOT BARESKIN_TESTS)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LINK} GTest::gtest_main)
  target_compile_options(${name} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  # Where tests find the setup assets and the fixture template (environment variables of the same name override).
  target_compile_definitions(${name} PRIVATE BARESKIN_TEST_ASSETS="${PROJECT_SOURCE_DIR}/assets"
                                             BARESKIN_TEST_TEMPLATE="${CMAKE_BINARY_DIR}/test_template")
  # A hang fails with the test's name instead of running into CI's limit (each test takes seconds to a minute).
  set(properties LABELS "${ARG_LABELS}" TIMEOUT 300)
  if(ARG_FIXTURES)
    list(APPEND properties FIXTURES_REQUIRED "${ARG_FIXTURES}")
  endif()
  gtest_discover_tests(${name} PROPERTIES ${properties} DISCOVERY_TIMEOUT 60)
endfunction()
include(GoogleTest)

# bareskin_torch(NAME): a Torch-side target. It reuses LibTorch's precompiled header (built once by bareskin_training)
# and, with BARESKIN_UNITY (default on), compiles its sources as one translation unit: on 2 cores every Torch file pays
# about 20 s of header work whatever its own size, so fewer, larger files build faster.
option(BARESKIN_UNITY "Unity builds for the Torch-side targets" ON)
function(bareskin_torch name)
  if(NOT TARGET ${name})
    return()
  endif()
  target_precompile_headers(${name} REUSE_FROM bareskin_training)
  set_target_properties(${name} PROPERTIES UNITY_BUILD ${BARESKIN_UNITY} UNITY_BUILD_BATCH_SIZE 0)
endfunction()

# bareskin_torch_test(SOURCES ... LINK ... DEFINITIONS ... FIXTURES ...): a folder's Torch-side tests. They join one
# GoogleTest binary, bin/torch_test, which bareskin_torch_tests() makes once every folder has added its own: each Torch
# translation unit pays ~15 CPU-s of LibTorch headers on 2 cores (the precompiled header included), so the tests of
# eleven folders build as two unity units instead of eleven. CTest names the tests as before (Suite.Name).
function(bareskin_torch_test)
  cmake_parse_arguments(ARG "" "" "SOURCES;LINK;DEFINITIONS;FIXTURES" ${ARGN})
  if(NOT BARESKIN_TESTS)
    return()
  endif()
  foreach(source IN LISTS ARG_SOURCES)
    get_filename_component(path "${source}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    set_property(GLOBAL APPEND PROPERTY BARESKIN_TORCH_TEST_SOURCES "${path}")
  endforeach()
  set_property(GLOBAL APPEND PROPERTY BARESKIN_TORCH_TEST_LINK ${ARG_LINK})
  set_property(GLOBAL APPEND PROPERTY BARESKIN_TORCH_TEST_DEFINITIONS ${ARG_DEFINITIONS})
  set_property(GLOBAL APPEND PROPERTY BARESKIN_TORCH_TEST_FIXTURES ${ARG_FIXTURES})
endfunction()

function(bareskin_torch_tests)
  get_property(sources GLOBAL PROPERTY BARESKIN_TORCH_TEST_SOURCES)
  if(NOT sources)
    return()
  endif()
  get_property(link GLOBAL PROPERTY BARESKIN_TORCH_TEST_LINK)
  get_property(definitions GLOBAL PROPERTY BARESKIN_TORCH_TEST_DEFINITIONS)
  get_property(fixtures GLOBAL PROPERTY BARESKIN_TORCH_TEST_FIXTURES)
  list(REMOVE_DUPLICATES link)
  if(fixtures)
    list(REMOVE_DUPLICATES fixtures)
  endif()
  bareskin_test(torch_test SOURCES ${sources} LINK ${link} LABELS torch FIXTURES ${fixtures})
  bareskin_torch(torch_test)
  target_compile_definitions(torch_test PRIVATE ${definitions})
  # Two units, so that the last one to start does not hold the end of a 2-core build alone.
  list(LENGTH sources count)
  math(EXPR half "(${count} + 1) / 2")
  set_target_properties(torch_test PROPERTIES UNITY_BUILD_BATCH_SIZE ${half})
endfunction()
