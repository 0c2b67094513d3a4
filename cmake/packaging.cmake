# The Debian package (CPack DEB): `cpack -G DEB` in a build tree configured with the prefix /usr
# (the default) makes hmdnode_<version>_amd64.deb of what the install rules install
# (firmware_host/CMakeLists.txt). Its Depends are the Debian runtime packages of the libraries
# the executables link (dpkg-shlibdeps: libvulkan1, libegl1, libgles2, libdrm2 and libgbm1 for
# the KMS display among them), plus the Vulkan driver and Mesa's EGL vendor library (the GLES backend), which are
# loaded, not linked.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME hmdnode)
set(CPACK_PACKAGE_VENDOR "hmdnode")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "rendering node for head-mounted displays (daemon and tools)")
set(CPACK_PACKAGE_DESCRIPTION "hmdnoded renders a scene for a head-mounted display from a \
head tracker, with LOD selection, pose prediction and late warp; hmdnode replays traces, records \
trackers and makes LOD chains and lightmaps. With a systemd unit, udev rules and a config that \
runs on simulated devices.")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # hmdnode_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "hmdnode maintainers <hmdnode@localhost>")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "mesa-vulkan-drivers | vulkan-icd, libegl-mesa0 | libegl-vendor")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "systemd, udev")
# note: the maintainer scripts and the config as a conffile (an edited config survives upgrades).
file(WRITE ${CMAKE_BINARY_DIR}/packaging/conffiles "/etc/hmdnode/hmdnoded.json\n")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${CMAKE_SOURCE_DIR}/firmware_host/packaging/postinst
    ${CMAKE_SOURCE_DIR}/firmware_host/packaging/prerm
    ${CMAKE_SOURCE_DIR}/firmware_host/packaging/postrm
    ${CMAKE_BINARY_DIR}/packaging/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
