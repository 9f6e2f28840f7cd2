# `make package` (root Makefile) / `cpack -G DEB` in the build folder: the Debian package
# hfrt_VERSION_amd64.deb with everything `cmake --install` installs (the hfrt executable,
# libhfrt.so, the public headers, the CMake package, hfrt.pc and the Python module), installed
# under /usr. Depends is computed by dpkg-shlibdeps from the ELF files (dpkg-dev), plus the
# Python interpreter and NumPy for the module.
set(CPACK_GENERATOR "DEB")
set(CPACK_PACKAGE_NAME "hfrt")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
set(CPACK_PACKAGE_CONTACT "hfrt developers <hfrt@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
  "HyperFun FRep compiler (LLVM JIT) and ray tracer, with C, C++ and Python APIs")
set(CPACK_PACKAGING_INSTALL_PREFIX "/usr")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # hfrt_VERSION_ARCH.deb
set(CPACK_DEBIAN_PACKAGE_SECTION "graphics")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# dpkg-shlibdeps must find libhfrt.so itself (installed in the same package).
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3 (>= 3.11), python3-numpy")
set(CPACK_STRIP_FILES ON)
include(CPack)
