# Install rules (docs/packaging.md). Two components:
#   runtime: the CLI, the preload library, the bench task, the example
#            policies and scenarios, man pages, bash completion, systemd
#            units and the system files (the `contego` package);
#   dev:     the trusted core as a static library with its public headers,
#            its CMake package config and pkg-config file (`contego-dev`).
# Data is found relative to the executable (src/cli/install_paths.h), so a
# tree installed under any prefix works where it is.
include(CMakePackageConfigHelpers)

set(CONTEGO_SYSTEM_DIR ${PROJECT_SOURCE_DIR}/packaging/system)
# systemd's, udev's and logrotate's directories. Under /usr they are the
# distribution's (/usr/lib/systemd/system ..., /etc/logrotate.d); under any
# other prefix they stay inside it.
# Relative destinations, so that `cmake --install --prefix DIR` moves them
# too; /etc is absolute only for the /usr prefix (GNUInstallDirs' rule).
set(CONTEGO_UNIT_DIR lib/systemd/system)
set(CONTEGO_SYSUSERS_DIR lib/sysusers.d)
set(CONTEGO_TMPFILES_DIR lib/tmpfiles.d)
set(CONTEGO_UDEV_DIR lib/udev/rules.d)
set(CONTEGO_CATALOG_DIR lib/systemd/catalog)
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(CONTEGO_ETC_DIR ${CMAKE_INSTALL_FULL_SYSCONFDIR})
else()
  set(CONTEGO_ETC_DIR ${CMAKE_INSTALL_SYSCONFDIR})
endif()

# --- runtime ---------------------------------------------------------------
install(TARGETS contego contego-monitor RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(TARGETS contego_preload LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime)
install(TARGETS contego-bench-task RUNTIME DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/contego
        COMPONENT runtime)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/policies ${PROJECT_SOURCE_DIR}/scenarios
        DESTINATION ${CMAKE_INSTALL_DATADIR}/contego COMPONENT runtime)

foreach(unit contego-monitor.service contego-run@.service contego-kmod-audit.service
             contego-kmod-load.service)
  configure_file(${CONTEGO_SYSTEM_DIR}/${unit}.in ${PROJECT_BINARY_DIR}/packaging/${unit} @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/packaging/${unit} DESTINATION ${CONTEGO_UNIT_DIR}
          COMPONENT runtime)
endforeach()
install(FILES ${CONTEGO_SYSTEM_DIR}/contego.sysusers DESTINATION ${CONTEGO_SYSUSERS_DIR}
        RENAME contego.conf COMPONENT runtime)
install(FILES ${CONTEGO_SYSTEM_DIR}/contego.tmpfiles DESTINATION ${CONTEGO_TMPFILES_DIR}
        RENAME contego.conf COMPONENT runtime)
# The journal's catalog of the monitor's MESSAGE_IDs (systemd's dpkg trigger
# runs journalctl --update-catalog).
install(FILES ${CONTEGO_SYSTEM_DIR}/contego.catalog DESTINATION ${CONTEGO_CATALOG_DIR}
        COMPONENT runtime)
install(FILES ${CONTEGO_SYSTEM_DIR}/99-contego-i2c.rules DESTINATION ${CONTEGO_UDEV_DIR}
        COMPONENT runtime)
install(FILES ${CONTEGO_SYSTEM_DIR}/contego.logrotate DESTINATION ${CONTEGO_ETC_DIR}/logrotate.d
        RENAME contego COMPONENT runtime)
install(FILES ${CONTEGO_SYSTEM_DIR}/contego.default DESTINATION ${CONTEGO_ETC_DIR}/default
        RENAME contego COMPONENT runtime)
install(DIRECTORY DESTINATION ${CONTEGO_ETC_DIR}/contego/run COMPONENT runtime)
install(FILES ${CONTEGO_SYSTEM_DIR}/contego-run.conf.example ${PROJECT_SOURCE_DIR}/README.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime)
# The documentation on the robot, where the README and the man pages point:
# the policy language, deployment, kernel client, threat model, examples
# (docs/performance-journal.md, the measurement history, stays in the tree).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT runtime
        PATTERN "performance-journal.md" EXCLUDE)

# Man pages and bash completion, generated from the CLI's --help
# (tools/cli_docs.py); a cross build runs the CLI under its emulator.
set(CONTEGO_CLI_DOCS ${PROJECT_BINARY_DIR}/cli-docs)
add_custom_command(
  OUTPUT ${CONTEGO_CLI_DOCS}/man1/contego.1 ${CONTEGO_CLI_DOCS}/bash-completion/contego
  COMMAND python3 ${PROJECT_SOURCE_DIR}/tools/cli_docs.py ${CONTEGO_CLI_DOCS} ${PROJECT_VERSION}
          -- ${CMAKE_CROSSCOMPILING_EMULATOR} $<TARGET_FILE:contego>
  DEPENDS contego ${PROJECT_SOURCE_DIR}/tools/cli_docs.py
  COMMENT "Man pages and bash completion from contego --help" VERBATIM)
add_custom_target(contego_cli_docs ALL
  DEPENDS ${CONTEGO_CLI_DOCS}/man1/contego.1 ${CONTEGO_CLI_DOCS}/bash-completion/contego)
install(DIRECTORY ${CONTEGO_CLI_DOCS}/man1 DESTINATION ${CMAKE_INSTALL_MANDIR} COMPONENT runtime)
install(FILES ${CONTEGO_CLI_DOCS}/bash-completion/contego
        DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions COMPONENT runtime)

# --- dev: the trusted core -------------------------------------------------
set_target_properties(contego_core PROPERTIES EXPORT_NAME core)
target_include_directories(contego_core INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
install(TARGETS contego_core EXPORT contegoTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/contego DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        COMPONENT dev)
set(CONTEGO_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/contego)
install(EXPORT contegoTargets NAMESPACE contego:: DESTINATION ${CONTEGO_CMAKE_DIR} COMPONENT dev)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/contegoConfig.cmake.in
  ${PROJECT_BINARY_DIR}/contegoConfig.cmake INSTALL_DESTINATION ${CONTEGO_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/contegoConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/contegoConfig.cmake ${PROJECT_BINARY_DIR}/contegoConfigVersion.cmake
        DESTINATION ${CONTEGO_CMAKE_DIR} COMPONENT dev)
file(RELATIVE_PATH CONTEGO_PC_TO_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
configure_file(${PROJECT_SOURCE_DIR}/cmake/contego.pc.in ${PROJECT_BINARY_DIR}/contego.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/contego.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig
        COMPONENT dev)
