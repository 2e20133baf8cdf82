# Small helpers shared by every folder's CMakeLists.txt.

set(CONTEGO_WARNINGS -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion)
if(CONTEGO_WERROR)
  list(APPEND CONTEGO_WARNINGS -Werror)
endif()

# contego_library(NAME SOURCES ... DEPS ...): a static library of one layer.
function(contego_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  # BUILD_INTERFACE: an installed library (the core) names no source-tree path.
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
                                            $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>)
  target_compile_options(${name} PRIVATE ${CONTEGO_WARNINGS})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
endfunction()

# contego_use_core_lto(TARGET): with CONTEGO_CORE_LTO, TARGET links the
# core's bytecode copy (src/core) and optimises it at link time. Declare it
# after TARGET's target_link_libraries; a no-op otherwise.
function(contego_use_core_lto target)
  if(TARGET contego_core_lto)
    target_sources(${target} PRIVATE $<TARGET_OBJECTS:contego_core_lto>)
    target_link_options(${target} PRIVATE -flto=auto)
  endif()
endfunction()

# contego_test(NAME SOURCES ... DEPS ... [SERIAL FILTER]): a GoogleTest binary
# registered with CTest. The tests SERIAL's gtest filter names run alone
# (RUN_SERIAL): they judge the scheduler's placement or timing, which a test
# running beside them on a two-CPU machine decides instead.
function(contego_test name)
  if(NOT CONTEGO_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "SERIAL" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/include ${PROJECT_SOURCE_DIR}/src)
  target_compile_options(${name} PRIVATE ${CONTEGO_WARNINGS})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main GTest::gmock)
  # Tests measure nothing: no link-time optimisation (CONTEGO_LTO); they link
  # the libraries' machine code. (LTO's whole-program inlining also wakes
  # GCC 12's false -Wstringop-overflow and -overread in std::string and
  # std::vector code.)
  set_property(TARGET ${name} PROPERTY INTERPROCEDURAL_OPTIMIZATION OFF)
  if(ARG_SERIAL)
    gtest_discover_tests(${name} TEST_FILTER "-${ARG_SERIAL}" PROPERTIES LABELS "${ARG_LABELS}"
                         DISCOVERY_TIMEOUT 60)
    gtest_discover_tests(${name} TEST_FILTER "${ARG_SERIAL}"
                         PROPERTIES LABELS "${ARG_LABELS}" RUN_SERIAL TRUE DISCOVERY_TIMEOUT 60)
  else()
    gtest_discover_tests(${name} PROPERTIES LABELS "${ARG_LABELS}" DISCOVERY_TIMEOUT 60)
  endif()
endfunction()

# contego_cli_script_test(NAME SCRIPT [TIMEOUT SECONDS] [PASS REGEX] ARGS ...):
# `bash SCRIPT <the contego executable> ARGS...` as the CTest test NAME, label
# `cli`; it passes when the script prints `ok` on a line of its own (PASS
# overrides that). Registered only when the `contego` executable and the
# policy compiler are built.
function(contego_cli_script_test name script)
  if(NOT (TARGET contego AND TARGET contego_policy))
    return()
  endif()
  cmake_parse_arguments(ARG "" "TIMEOUT;PASS" "ARGS" ${ARGN})
  if(NOT ARG_PASS)
    set(ARG_PASS "^ok|\nok")
  endif()
  add_test(NAME ${name} COMMAND bash ${script} $<TARGET_FILE:contego> ${ARG_ARGS})
  set_tests_properties(${name} PROPERTIES LABELS cli PASS_REGULAR_EXPRESSION "${ARG_PASS}")
  if(ARG_TIMEOUT)
    set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  endif()
endfunction()

# contego_source_check(TEST TOOL PLANTED_TEST PLANTED_SCRIPT LABELS ...): a
# check of the source tree, `TOOL <source dir>` (a Python script) as the CTest
# test TEST, and PLANTED_TEST, `bash PLANTED_SCRIPT <source dir>`, which plants
# violations into a copy of the tree and expects TOOL to name each one.
function(contego_source_check test tool planted_test planted_script)
  cmake_parse_arguments(ARG "" "" "LABELS" ${ARGN})
  find_package(Python3 REQUIRED COMPONENTS Interpreter)
  add_test(NAME ${test} COMMAND Python3::Interpreter ${tool} ${PROJECT_SOURCE_DIR})
  add_test(NAME ${planted_test} COMMAND bash ${planted_script} ${PROJECT_SOURCE_DIR})
  set_tests_properties(${test} ${planted_test} PROPERTIES LABELS "${ARG_LABELS}")
endfunction()
