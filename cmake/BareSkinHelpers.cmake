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
