# Warning and optimization flags carried by INTERFACE targets, and small helpers that declare
# one library / test / benchmark per call.

add_library(shrm_warnings INTERFACE)
target_compile_options(shrm_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
                       -Wnon-virtual-dtor -Wno-unused-parameter)

add_library(shrm_opt INTERFACE)
if(SHRM_NATIVE)
  target_compile_options(shrm_opt INTERFACE -march=native)
endif()
target_compile_options(shrm_opt INTERFACE $<$<CONFIG:Release>:-O3> -fno-math-errno)

# shrm_add_library(name SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
function(shrm_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  # Installed headers are found through the exported targets (cmake/ShrmInstall.cmake).
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS}
                        $<BUILD_INTERFACE:shrm_warnings> $<BUILD_INTERFACE:shrm_opt>)
endfunction()

# shrm_add_test(name SOURCES ... DEPS ...): a GoogleTest binary registered with CTest.
function(shrm_add_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main shrm_warnings
                        shrm_opt)
  target_compile_definitions(${name} PRIVATE SHRM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
endfunction()

# shrm_add_bench(name SOURCES ... DEPS ...): a Google Benchmark program.
function(shrm_add_bench name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark shrm_warnings shrm_opt)
  target_compile_definitions(${name} PRIVATE SHRM_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endfunction()
