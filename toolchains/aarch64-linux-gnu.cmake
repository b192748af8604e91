# 64-bit Arm robot computers (Raspberry Pi 4/5, Jetson-class). Prepare with
# scripts/setup-cross.sh aarch64; build with scripts/build-cross.sh aarch64.
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CAIRN_TRIPLE aarch64-linux-gnu)
set(CAIRN_QEMU qemu-aarch64)
set(CAIRN_DEB_ARCH arm64)
include(${CMAKE_CURRENT_LIST_DIR}/cross-common.cmake)
