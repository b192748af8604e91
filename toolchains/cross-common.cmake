# Shared by the toolchain files: a Debian cross compiler and the target's libraries, from a
# sysroot (CAIRN_SYSROOT) or from Debian multiarch (/usr/lib/<triple>, /usr/include/<triple>),
# both prepared by scripts/setup-cross.sh. Host programs (idlc) are found on the host; target
# libraries and pkg-config files only for the target. CTest runs the target's test binaries
# through qemu-user with the target's own loader.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_C_COMPILER ${CAIRN_TRIPLE}-gcc)
set(CMAKE_CXX_COMPILER ${CAIRN_TRIPLE}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${CAIRN_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(ENV{PKG_CONFIG_PATH} "")
if(CAIRN_SYSROOT)
  # The target's own root (headers, libraries, CMake and pkg-config files), and nothing of
  # the host's except programs.
  get_filename_component(CAIRN_SYSROOT ${CAIRN_SYSROOT} ABSOLUTE)
  if(NOT EXISTS ${CAIRN_SYSROOT}/.cairn-packages)
    message(FATAL_ERROR "no ${CAIRN_DEB_ARCH} sysroot at ${CAIRN_SYSROOT}: run scripts/setup-cross.sh ${CAIRN_DEB_ARCH}")
  endif()
  set(CMAKE_SYSROOT ${CAIRN_SYSROOT})
  set(CMAKE_FIND_ROOT_PATH ${CAIRN_SYSROOT})
  set(cairn_find_mode ONLY)
  set(ENV{PKG_CONFIG_SYSROOT_DIR} ${CAIRN_SYSROOT})
  set(ENV{PKG_CONFIG_LIBDIR} "${CAIRN_SYSROOT}/usr/lib/${CAIRN_TRIPLE}/pkgconfig:${CAIRN_SYSROOT}/usr/share/pkgconfig")
  # The sysroot's loader with the sysroot's libc: one consistent set.
  set(CMAKE_CROSSCOMPILING_EMULATOR ${CAIRN_QEMU};-L;${CAIRN_SYSROOT})
else()
  set(CMAKE_FIND_ROOT_PATH /usr/${CAIRN_TRIPLE})
  # Multiarch libraries live in /usr/lib/<triple>, outside the root path: search both.
  set(cairn_find_mode BOTH)
  set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${CAIRN_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
  # The loader must be the multiarch one (libc6:<arch>, /lib/ld-linux-*.so), matching the
  # multiarch libc.so.6 it then finds. `-L /usr/<triple>` would pair the cross toolchain's
  # older ld.so with the newer multiarch libc: their private ABI differs, and pthread_create
  # spins forever walking a misread stack-cache list.
  set(CMAKE_CROSSCOMPILING_EMULATOR ${CAIRN_QEMU};-L;/)
endif()
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ${cairn_find_mode})
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ${cairn_find_mode})
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ${cairn_find_mode})
