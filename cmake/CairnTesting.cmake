# cairn_add_test(NAME name SOURCES ... LIBS ... LABELS ... [TIMEOUT s] [COUNT_ALLOCS])
# One GoogleTest executable registered as one CTest test with the area labels.
# COUNT_ALLOCS: outside the sanitizers' builds, links the counting allocator
# (tests/support/alloc_counter.cpp) and defines CAIRN_COUNT_ALLOCS, so the test can prove
# its subject allocates nothing; under the sanitizers neither (the counting malloc would
# bypass their own allocator).
# Every test runs with the project's loopback-only Cyclone DDS profile.
set(CAIRN_TEST_ENVIRONMENT
  "CYCLONEDDS_URI=file://${PROJECT_SOURCE_DIR}/config/dds/loopback.xml"
  "CAIRN_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
  "CAIRN_BINARY_DIR=${PROJECT_BINARY_DIR}"
  "TSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/tests/tsan.supp")

# One precompiled header for every test: GoogleTest, Eigen and the standard headers most
# tests include, parsed once per build instead of once per test (GoogleTest alone is about
# 2 s of each test's compile, and a CI run builds the tests five times). The tests reuse
# it, so they compile with its flags (warnings, -O0 under the sanitizers); -Winvalid-pch,
# which CMake adds, makes a mismatch an error under -Werror rather than a silent slow build.
set(CAIRN_TEST_PCH_HEADERS
  <gtest/gtest.h> <Eigen/Dense>
  <algorithm> <array> <atomic> <chrono> <cmath> <cstdint> <cstdio> <cstdlib> <cstring>
  <filesystem> <fstream> <functional> <limits> <map> <memory> <mutex> <numbers> <optional>
  <random> <set> <sstream> <string> <thread> <vector>)
function(cairn_test_pch)
  if(TARGET cairn_test_pch)
    return()
  endif()
  add_library(cairn_test_pch OBJECT ${PROJECT_SOURCE_DIR}/tests/support/test_pch.cpp
                                    ${PROJECT_SOURCE_DIR}/tests/support/test_pch_c.c)
  target_link_libraries(cairn_test_pch PRIVATE GTest::gtest Eigen3::Eigen)
  cairn_warnings(cairn_test_pch)
  cairn_unoptimized_when_sanitized(cairn_test_pch)
  cairn_layer(cairn_test_pch tests)
  # A test that links the DDS layer counts as having C too (the generated cairn.c): CMake
  # then wants a C header to reuse as well, a trivial one. ($<ANGLE-R>: a '>' inside a
  # generator expression.)
  set(headers "$<$<COMPILE_LANGUAGE:C>:<stdint.h$<ANGLE-R>>")
  foreach(h IN LISTS CAIRN_TEST_PCH_HEADERS)
    string(REPLACE ">" "$<ANGLE-R>" h "${h}")
    list(APPEND headers "$<$<COMPILE_LANGUAGE:CXX>:${h}>")
  endforeach()
  target_precompile_headers(cairn_test_pch PRIVATE ${headers})
endfunction()

function(cairn_add_test)
  cmake_parse_arguments(T "COUNT_ALLOCS" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  cairn_test_pch()
  if(T_COUNT_ALLOCS AND NOT CAIRN_SANITIZE)
    list(APPEND T_SOURCES ${PROJECT_SOURCE_DIR}/tests/support/alloc_counter.cpp)
  endif()
  add_executable(${T_NAME} ${T_SOURCES})
  if(T_COUNT_ALLOCS AND NOT CAIRN_SANITIZE)
    target_compile_definitions(${T_NAME} PRIVATE CAIRN_COUNT_ALLOCS)
  endif()
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest_main)
  target_precompile_headers(${T_NAME} REUSE_FROM cairn_test_pch)
  cairn_warnings(${T_NAME})
  cairn_unoptimized_when_sanitized(${T_NAME})
  cairn_layer(${T_NAME} tests)
  # `single-threaded`: the code under test starts no thread. TSan has nothing to find there,
  # so the TSan build neither builds nor runs it (it stays a target: later properties and
  # dependencies still apply). Elsewhere (not under the sanitizers, which hook thread
  # creation themselves) the guard fails the test if it starts a thread after all.
  if("single-threaded" IN_LIST T_LABELS)
    if(CAIRN_SANITIZE STREQUAL "thread")
      set_target_properties(${T_NAME} PROPERTIES EXCLUDE_FROM_ALL TRUE)
      return()
    elseif(NOT CAIRN_SANITIZE)
      target_sources(${T_NAME} PRIVATE ${PROJECT_SOURCE_DIR}/tests/support/single_threaded_guard.cpp)
    endif()
  endif()
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 120)
  endif()
  add_test(NAME ${T_NAME} COMMAND ${T_NAME})
  if(CMAKE_CROSSCOMPILING)
    # Run under qemu-user (the toolchain's CROSSCOMPILING_EMULATOR); a failure names the target.
    list(APPEND T_LABELS cross ${CMAKE_SYSTEM_PROCESSOR})
    math(EXPR T_TIMEOUT "${T_TIMEOUT} * 4")
    target_compile_definitions(${T_NAME} PRIVATE CAIRN_EMULATED=1)  # timing bounds scale (timing.hpp)
  endif()
  set_tests_properties(${T_NAME} PROPERTIES
    LABELS "${T_LABELS}"
    TIMEOUT ${T_TIMEOUT}
    ENVIRONMENT "${CAIRN_TEST_ENVIRONMENT}")
endfunction()
