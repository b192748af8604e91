# Debian packages per architecture (CPack DEB, one package per component):
#   cairn-robot  cairn-robot, cairn-lms-probe, /etc/cairn/robot.toml, the systemd unit,
#                the udev rule template for the laser's serial adapter, a sysctl.d file
#   cairn-base   cairn-base, cairn-eval, /etc/cairn/base.toml, the systemd unit  (host builds)
#   cairn-hil    cairn-hil, the worlds and the robot template                      (host builds)
# Built by scripts/package.sh; the architecture is the toolchain's (CAIRN_DEB_ARCH) or the host's.
if(CAIRN_DEB_ARCH)
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE ${CAIRN_DEB_ARCH})
else()
  execute_process(COMMAND dpkg --print-architecture OUTPUT_VARIABLE CPACK_DEBIAN_PACKAGE_ARCHITECTURE
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
endif()

set(cairn_pkg ${PROJECT_SOURCE_DIR}/packaging)
install(TARGETS cairn-robot cairn-lms-probe RUNTIME DESTINATION bin COMPONENT robot)
install(FILES config/robot.toml DESTINATION /etc/cairn COMPONENT robot)
install(FILES config/dds/lan.xml config/dds/loopback.xml DESTINATION share/cairn/dds COMPONENT robot)
install(FILES ${cairn_pkg}/robot/cairn-robot.service DESTINATION /lib/systemd/system COMPONENT robot)
install(FILES ${cairn_pkg}/robot/99-cairn-lms.rules DESTINATION share/cairn/udev COMPONENT robot)
# The network's ARP queue per neighbour (packaging/sysctl/cairn-network.conf says why).
install(FILES ${cairn_pkg}/sysctl/cairn-network.conf DESTINATION /usr/lib/sysctl.d RENAME 60-cairn-robot.conf COMPONENT robot)
install(FILES docs/firmware.md docs/config.md docs/lms2xx.md docs/canopen.md docs/modbus.md docs/dds.md
        DESTINATION share/doc/cairn-robot COMPONENT robot)
set(CPACK_COMPONENTS_ALL robot)

if(CAIRN_HOST_ONLY_PARTS)
  install(TARGETS cairn-base RUNTIME DESTINATION bin COMPONENT base)
  if(TARGET cairn-eval)  # tools/eval: built with the host-only parts
    install(TARGETS cairn-eval RUNTIME DESTINATION bin COMPONENT base)
  endif()
  if(TARGET cairn-map-quality)  # tools/map_quality: a map against a HIL world's ground truth
    install(TARGETS cairn-map-quality RUNTIME DESTINATION bin COMPONENT base)
  endif()
  if(TARGET cairn-fuzz-base)  # tools/fuzz_base: hostile DDS input against a base on loopback
    install(TARGETS cairn-fuzz-base RUNTIME DESTINATION bin COMPONENT base)
  endif()
  install(FILES config/base.toml DESTINATION /etc/cairn COMPONENT base)
  install(FILES ${cairn_pkg}/base/cairn-base.service DESTINATION /lib/systemd/system COMPONENT base)
  install(FILES ${cairn_pkg}/sysctl/cairn-network.conf DESTINATION /usr/lib/sysctl.d RENAME 60-cairn-base.conf COMPONENT base)
  install(FILES docs/ccml.md docs/mapper.md docs/config.md docs/dds.md DESTINATION share/doc/cairn-base COMPONENT base)

  install(TARGETS cairn-hil RUNTIME DESTINATION bin COMPONENT hil)
  install(DIRECTORY hil/worlds/ DESTINATION share/cairn/worlds COMPONENT hil FILES_MATCHING PATTERN "*.world")
  install(FILES config/robot-hil.toml config/base-hil.toml config/dds/loopback.xml DESTINATION share/cairn/hil COMPONENT hil)
  install(FILES docs/hil.md DESTINATION share/doc/cairn-hil COMPONENT hil)
  list(APPEND CPACK_COMPONENTS_ALL base hil)
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_PACKAGE_NAME cairn)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "Cairn developers <cairn-dev@example.org>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # Depends: from the binaries' libraries (dpkg-shlibdeps)
if(CMAKE_SYSROOT)  # cross with a sysroot: its libraries, and their symbols files in its DEBIAN/
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS
      ${CMAKE_SYSROOT}/lib/${CMAKE_LIBRARY_ARCHITECTURE} ${CMAKE_SYSROOT}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE})
endif()
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://example.org/cairn")

set(CPACK_DEBIAN_ROBOT_PACKAGE_NAME cairn-robot)
set(CPACK_COMPONENT_ROBOT_DESCRIPTION "Cairn robot executive\nThe real-time firmware of a laser-equipped mobile robot: SICK LMS2xx, CANopen CiA 402\ndrives and a Modbus power board, odometry, local scan matching, publishing over DDS.")
set(CPACK_DEBIAN_ROBOT_PACKAGE_DEPENDS "adduser")
set(CPACK_DEBIAN_ROBOT_PACKAGE_CONTROL_EXTRA
    "${cairn_pkg}/robot/postinst;${cairn_pkg}/robot/prerm;${cairn_pkg}/robot/postrm;${cairn_pkg}/robot/conffiles")
set(CPACK_DEBIAN_BASE_PACKAGE_NAME cairn-base)
set(CPACK_COMPONENT_BASE_DESCRIPTION "Cairn base station\nFuses a team of robots and their landmarks in one cooperative EKF (CCML) over DDS.")
set(CPACK_DEBIAN_BASE_PACKAGE_DEPENDS "adduser")
set(CPACK_DEBIAN_BASE_PACKAGE_CONTROL_EXTRA
    "${cairn_pkg}/base/postinst;${cairn_pkg}/base/prerm;${cairn_pkg}/base/postrm;${cairn_pkg}/base/conffiles")
set(CPACK_DEBIAN_HIL_PACKAGE_NAME cairn-hil)
set(CPACK_COMPONENT_HIL_DESCRIPTION "Cairn hardware-in-the-loop benches\nEmulators that speak the devices' wire protocols (LMS2xx, CiA 402 over CAN, Modbus)\nand simulated robots in a world, for test benches.")
include(CPack)
