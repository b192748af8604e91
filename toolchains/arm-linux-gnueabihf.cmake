# 32-bit Arm robot computers (ARMv7 with hard float). Prepare with
# scripts/setup-cross.sh armhf; build with scripts/build-cross.sh armhf. The target's
# libraries come from the sysroot that script unpacks (build/sysroot/armhf), not multiarch.
set(CMAKE_SYSTEM_PROCESSOR armv7l)
set(CAIRN_TRIPLE arm-linux-gnueabihf)
set(CAIRN_QEMU qemu-arm)
set(CAIRN_DEB_ARCH armhf)
# GCC notes every function passing a span or iterator that its ABI for such arguments
# changed in GCC 7.1: only code built with GCC < 7 could disagree, and bookworm has none.
set(CMAKE_CXX_FLAGS_INIT -Wno-psabi)
set(CAIRN_SYSROOT ${CMAKE_CURRENT_LIST_DIR}/../build/sysroot/armhf)
include(${CMAKE_CURRENT_LIST_DIR}/cross-common.cmake)
