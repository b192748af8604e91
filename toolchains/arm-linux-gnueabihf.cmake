# 32-bit Arm robot computers (ARMv7 with hard float). Prepare with
# scripts/setup-cross.sh armhf; build with scripts/build-cross.sh armhf.
set(CMAKE_SYSTEM_PROCESSOR armv7l)
set(CAIRN_TRIPLE arm-linux-gnueabihf)
set(CAIRN_QEMU qemu-arm)
set(CAIRN_DEB_ARCH armhf)
include(${CMAKE_CURRENT_LIST_DIR}/cross-common.cmake)
