# Debian packages through CPack's DEB generator (docs/packaging.md says why
# CPack rather than debhelper). `cpack -G DEB` in a `package` preset's build
# tree (tools/package.sh) writes
#   contego_VERSION_ARCH.deb        the CLI, preload library, data, units, system files
#   contego-dev_VERSION_ARCH.deb    the trusted core: static library, headers, CMake config, .pc
#   contego-dbgsym_VERSION_ARCH.ddeb  the runtime's debug symbols (split off, by build id)
#   contego-dkms_VERSION_all.deb    contego.ko's source for DKMS (cmake/ContegoDkms.cmake)
set(CPACK_PACKAGE_NAME contego)
set(CPACK_PACKAGE_VENDOR "contego")
set(CPACK_PACKAGE_CONTACT "contego maintainers <contego@localhost>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "actuator command firewall for real-time control systems")
set(CPACK_PACKAGE_DESCRIPTION
    "Every command a real-time task sends to an I2C actuator passes a small trusted checker that\n"
    "enforces an access matrix, per-job rate limits and state invariants, and answers a violation\n"
    "by dropping the command or substituting a safe one. Programs run unmodified.")
string(JOIN "" CPACK_PACKAGE_DESCRIPTION ${CPACK_PACKAGE_DESCRIPTION})
# Stripping is the DEB generator's: it copies the debug info of every
# unstripped ELF file into the -dbgsym package (by build id), then strips it
# (objcopy --strip-unneeded). Stripped at install time there would be
# nothing left to split off. A cross build uses the target's binutils.
set(CPACK_STRIP_FILES OFF)
set(CPACK_OBJCOPY_EXECUTABLE ${CMAKE_OBJCOPY})
set(CPACK_READELF_EXECUTABLE ${CMAKE_READELF})
set(CPACK_GENERATOR DEB)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev dkms)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# The target's Debian architecture (a cross build's, not the build machine's).
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(aarch64|arm64)$")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
elseif(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|amd64)$")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE amd64)
endif()

set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME contego)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SECTION admin)
# Shared-library dependencies from dpkg-shlibdeps (for a cross build it reads
# the multiarch packages' symbols files), plus what the maintainer scripts
# and the units use.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "adduser | systemd (>= 245)")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "systemd, logrotate")
# gnuplot draws `contego demo`/`sim` figures; without it they write CSV only.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SUGGESTS "i2c-tools, gnuplot-nox")
set(CPACK_DEBIAN_RUNTIME_DEBUGINFO_PACKAGE ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/deb/postinst ${PROJECT_SOURCE_DIR}/packaging/deb/prerm
    ${PROJECT_SOURCE_DIR}/packaging/deb/postrm ${PROJECT_SOURCE_DIR}/packaging/deb/conffiles)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_DEV_PACKAGE_NAME contego-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_ARCHITECTURE ${CPACK_DEBIAN_PACKAGE_ARCHITECTURE})
set(CPACK_COMPONENT_DEV_DESCRIPTION "contego's trusted core (static library, headers, CMake and pkg-config files)")

# Architecture-independent: sources DKMS compiles on the target for each of
# its kernels. The core is C++ (g++); DKMS brings gcc, make and kmod.
set(CPACK_DEBIAN_DKMS_PACKAGE_NAME contego-dkms)
set(CPACK_DEBIAN_DKMS_PACKAGE_SECTION kernel)
set(CPACK_DEBIAN_DKMS_PACKAGE_ARCHITECTURE all)
set(CPACK_DEBIAN_DKMS_PACKAGE_DEPENDS "dkms (>= 2.8), g++")
set(CPACK_DEBIAN_DKMS_PACKAGE_RECOMMENDS "contego (= ${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE})")
set(CPACK_DEBIAN_DKMS_PACKAGE_SHLIBDEPS OFF)
set(CPACK_COMPONENT_DKMS_DESCRIPTION
    "contego.ko, contego's kernel client, as source for DKMS: it takes i2c-dev's\n"
    "place for the adapters it is told to protect and checks every program's I2C\n"
    "calls with contego's trusted core (docs/kernel-client.md). DKMS builds it\n"
    "for each installed kernel that has its headers.")
string(JOIN "" CPACK_COMPONENT_DKMS_DESCRIPTION ${CPACK_COMPONENT_DKMS_DESCRIPTION})
set(CPACK_DEBIAN_DKMS_PACKAGE_CONTROL_EXTRA
    ${PROJECT_BINARY_DIR}/packaging/dkms/postinst ${PROJECT_BINARY_DIR}/packaging/dkms/prerm)
set(CPACK_DEBIAN_DKMS_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
