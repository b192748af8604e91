# Layering enforced by the compiler (docs/architecture.md, "Folders"; README.md, "Layers").
#
# Every #include is repository-root relative ("common/se2.hpp"), so one include root at
# the repository would let any file include any other. Instead each layer gets its own
# include root under ${CMAKE_BINARY_DIR}/layers/<layer>/ holding symbolic links to only
# the top-level folders that layer may include:
#
#   common       common
#   drivers      common drivers
#   firmware     common drivers firmware
#   basestation  common basestation
#   hil          common drivers hil          (driver codecs and transports, never firmware)
#   tools        every product layer + tools (never tests)
#   tests        everything
#
# A file that includes upward ("firmware/..." from drivers) does not find the header and
# fails to build. The generated DDS header cairn.h is not under these roots: it comes
# with the cairn_idl/cairn_dds targets' own include directories to whoever links them.
#
# Usage, once per target (libraries, programs, tests):
#   add_library(cairn_foo STATIC foo.cpp)
#   cairn_layer(cairn_foo drivers)
# The root is PRIVATE: a consumer never inherits a producer's root, it compiles with its
# own (every target declares one; a target without one finds no project header at all).
# tests/layers/ proves the enforcement (ctest -L layers).

set(CAIRN_LAYER_FOLDERS_common common)
set(CAIRN_LAYER_FOLDERS_drivers common drivers)
set(CAIRN_LAYER_FOLDERS_firmware common drivers firmware)
set(CAIRN_LAYER_FOLDERS_basestation common basestation)
set(CAIRN_LAYER_FOLDERS_hil common drivers hil)
set(CAIRN_LAYER_FOLDERS_tools common drivers firmware basestation hil tools)
set(CAIRN_LAYER_FOLDERS_tests common drivers firmware basestation hil tools tests)
set(CAIRN_LAYERS common drivers firmware basestation hil tools tests)
set(CAIRN_LAYERS_DIR ${CMAKE_BINARY_DIR}/layers)

# Rebuilt at every configure, so a changed table leaves no stale link behind
# (REMOVE_RECURSE removes the links, not what they point to).
file(REMOVE_RECURSE ${CAIRN_LAYERS_DIR})
foreach(layer IN LISTS CAIRN_LAYERS)
  file(MAKE_DIRECTORY ${CAIRN_LAYERS_DIR}/${layer})
  foreach(folder IN LISTS CAIRN_LAYER_FOLDERS_${layer})
    file(CREATE_LINK ${PROJECT_SOURCE_DIR}/${folder} ${CAIRN_LAYERS_DIR}/${layer}/${folder} SYMBOLIC)
  endforeach()
endforeach()

# cairn_layer(<target> <layer>): compile <target> against <layer>'s include root only.
function(cairn_layer target layer)
  if(NOT layer IN_LIST CAIRN_LAYERS)
    message(FATAL_ERROR "cairn_layer(${target} ${layer}): unknown layer; one of: ${CAIRN_LAYERS}")
  endif()
  get_target_property(previous ${target} CAIRN_LAYER)
  if(previous AND NOT previous STREQUAL layer)
    message(FATAL_ERROR "cairn_layer(${target} ${layer}): already in layer ${previous}")
  endif()
  set_target_properties(${target} PROPERTIES CAIRN_LAYER ${layer})
  target_include_directories(${target} PRIVATE ${CAIRN_LAYERS_DIR}/${layer})
endfunction()
