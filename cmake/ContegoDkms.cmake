# The dkms component (package contego-dkms, docs/kernel-client.md): the
# source tree DKMS builds contego.ko from, under PREFIX/src/contego-VERSION
# (/usr/src/contego-VERSION, where DKMS looks): the module's C driver, its
# Kbuild and shim headers, dkms.conf, and the trusted core's own sources and
# headers, and the shared i2c-dev model's, in the layout the Kbuild expects
# (include/, src/core/, src/i2cdev/). The same
# files kernel/build.sh builds from the repository: no second copy to keep.
set(CONTEGO_DKMS_BUILD ${PROJECT_BINARY_DIR}/packaging/dkms)
foreach(file dkms.conf postinst prerm)
  configure_file(${PROJECT_SOURCE_DIR}/packaging/dkms/${file}.in ${CONTEGO_DKMS_BUILD}/${file} @ONLY)
endforeach()
set(CONTEGO_DKMS_DIR src/contego-${PROJECT_VERSION})
file(GLOB CONTEGO_KMOD_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/kernel/contego*.c
     ${PROJECT_SOURCE_DIR}/kernel/contego*.h)
install(FILES ${CONTEGO_DKMS_BUILD}/dkms.conf ${PROJECT_SOURCE_DIR}/kernel/Kbuild ${CONTEGO_KMOD_SOURCES}
        DESTINATION ${CONTEGO_DKMS_DIR} COMPONENT dkms)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/kernel/include DESTINATION ${CONTEGO_DKMS_DIR}
        COMPONENT dkms FILES_MATCHING PATTERN "*.h")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/kernel/shim DESTINATION ${CONTEGO_DKMS_DIR}
        COMPONENT dkms FILES_MATCHING PATTERN "*.h")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/contego DESTINATION ${CONTEGO_DKMS_DIR}/include
        COMPONENT dkms FILES_MATCHING PATTERN "*.h")
# The core's sources, not its tests.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/core/ DESTINATION ${CONTEGO_DKMS_DIR}/src/core
        COMPONENT dkms FILES_MATCHING PATTERN "*.cc" PATTERN "*.h" PATTERN "*test*" EXCLUDE)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/i2cdev/ DESTINATION ${CONTEGO_DKMS_DIR}/src/i2cdev
        COMPONENT dkms FILES_MATCHING PATTERN "*.cc" PATTERN "*test*" EXCLUDE)
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/contego-dkms
        COMPONENT dkms)
