# Helpers shared by every module's CMakeLists.

# Warnings on for every biodyn target; errors in CI (BIODYN_WARNINGS_AS_ERRORS), except in the
# sanitized build: GCC's instrumentation gives false -Wmaybe-uninitialized (in libstdc++'s
# <regex> here) and its manual recommends against -Werror with sanitizers. CI's normal build
# keeps the warnings honest.
function(biodyn_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion)
  if(BIODYN_SANITIZE)
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  elseif(BIODYN_WARNINGS_AS_ERRORS)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# biodyn_add_library(<module> SOURCES ... DEPS ... [INCLUDE_DIR dir]): the module's library target
# `biodyn_<module>` with alias `biodyn::<module>` and public headers in
# <module>/include/biodyn/<module>/.
function(biodyn_add_library module)
  cmake_parse_arguments(ARG "" "INCLUDE_DIR" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  if(NOT ARG_INCLUDE_DIR)
    set(ARG_INCLUDE_DIR ${CMAKE_CURRENT_SOURCE_DIR}/include)
  endif()
  add_library(biodyn_${module} ${ARG_SOURCES})
  add_library(biodyn::${module} ALIAS biodyn_${module})
  target_include_directories(biodyn_${module} PUBLIC ${ARG_INCLUDE_DIR})
  target_link_libraries(biodyn_${module} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  biodyn_target_warnings(biodyn_${module})
endfunction()

# biodyn_add_test(<name> SOURCES ... DEPS ...): one Catch2 executable whose test cases ctest
# discovers one by one after each build ("<name>: <test case>"), so `ctest -j` spreads them over
# the cores and `ctest -R '^<name>:'` runs one module's. Cases tagged [slow] get the label `slow`
# and a high COST, so ctest starts them first; `ctest -LE slow` runs the quick ones. Every test
# links biodyn_test_support (Catch2's main, the MuJoCo warning guard, the source and build
# directories). `--warn NoTests` fails a test whose name matches no case. Names must not contain ';' (a CMake list separator).
function(biodyn_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE biodyn_test_support ${ARG_DEPS})
  biodyn_target_warnings(${name})
  target_precompile_headers(${name} REUSE_FROM biodyn_test_pch)
  catch_discover_tests(${name} TEST_SPEC "~[slow]" TEST_PREFIX "${name}: " EXTRA_ARGS --reporter compact --warn NoTests)
  catch_discover_tests(${name} TEST_SPEC "[slow]" TEST_PREFIX "${name}: " EXTRA_ARGS --reporter compact --warn NoTests
                       PROPERTIES LABELS slow COST 100)
endfunction()

# biodyn_embed_files(<target> <namespace> FILES ...): compiles data files into <target> as
# string constants so installed binaries need no data path; the files stay the source of truth.
function(biodyn_embed_files target ns)
  cmake_parse_arguments(ARG "" "" "FILES" ${ARGN})
  set(out ${CMAKE_CURRENT_BINARY_DIR}/embedded_${target}.cc)
  set(abs_files)
  foreach(f ${ARG_FILES})
    list(APPEND abs_files ${CMAKE_CURRENT_SOURCE_DIR}/${f})
  endforeach()
  # A list can't cross the command line intact: pass it '|'-separated.
  string(REPLACE ";" "|" files_arg "${abs_files}")
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} -DNS=${ns} "-DFILES=${files_arg}"
            -P ${PROJECT_SOURCE_DIR}/cmake/embed_files.cmake
    DEPENDS ${abs_files} ${PROJECT_SOURCE_DIR}/cmake/embed_files.cmake
    COMMENT "Embedding data files into ${target}"
    VERBATIM)
  target_sources(${target} PRIVATE ${out})
endfunction()
