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
