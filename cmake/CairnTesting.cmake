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

# CAIRN_TEST_LABELS (a regex; empty: all): only the tests with a label it matches are built
# and registered; the others stay targets, out of `all` (scripts/build-cross.sh --tests-labelled).
set(CAIRN_TEST_LABELS "" CACHE STRING "Build and register only the tests with a label matching this regex (empty: all)")
if(CAIRN_TEST_LABELS AND NOT CMAKE_CROSSCOMPILING)
  # The host's tests/CMakeLists.txt sets properties on tests by name: a subset would break it.
  message(FATAL_ERROR "CAIRN_TEST_LABELS is for the cross presets (scripts/build-cross.sh --tests-labelled)")
endif()

function(cairn_add_test)
  cmake_parse_arguments(T "COUNT_ALLOCS" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  set(T_PICKED TRUE)
  if(CAIRN_TEST_LABELS)
    set(T_PICKED FALSE)
    foreach(label IN LISTS T_LABELS)
      if(label MATCHES "${CAIRN_TEST_LABELS}")
        set(T_PICKED TRUE)
      endif()
    endforeach()
  endif()
  if(T_COUNT_ALLOCS AND NOT CAIRN_SANITIZE)
    list(APPEND T_SOURCES ${PROJECT_SOURCE_DIR}/tests/support/alloc_counter.cpp)
  endif()
  add_executable(${T_NAME} ${T_SOURCES})
  if(T_COUNT_ALLOCS AND NOT CAIRN_SANITIZE)
    target_compile_definitions(${T_NAME} PRIVATE CAIRN_COUNT_ALLOCS)
  endif()
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest_main)
  cairn_warnings(${T_NAME})
  cairn_unoptimized_when_sanitized(${T_NAME})
  cairn_layer(${T_NAME} tests)
  # `single-threaded`: the code under test starts no thread. TSan has nothing to find there,
  # so the TSan build neither builds nor runs it (it stays a target: later properties and
  # dependencies still apply). Elsewhere (not under the sanitizers, which hook thread
  # creation themselves) the guard fails the test if it starts a thread after all.
  if("single-threaded" IN_LIST T_LABELS AND CAIRN_SANITIZE STREQUAL "thread")
    set(T_PICKED FALSE)
  endif()
  if(NOT T_PICKED)
    set_target_properties(${T_NAME} PROPERTIES EXCLUDE_FROM_ALL TRUE)
    return()
  endif()
  if("single-threaded" IN_LIST T_LABELS)
    if(NOT CAIRN_SANITIZE)
      if(NOT TARGET cairn_single_threaded_guard)  # compiled once, linked into each such test
        add_library(cairn_single_threaded_guard OBJECT ${PROJECT_SOURCE_DIR}/tests/support/single_threaded_guard.cpp)
        cairn_warnings(cairn_single_threaded_guard)
        cairn_layer(cairn_single_threaded_guard tests)
      endif()
      target_link_libraries(${T_NAME} PRIVATE cairn_single_threaded_guard)
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
