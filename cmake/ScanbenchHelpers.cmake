# Small helpers so that a library, a test or a benchmark is a few lines.

set(SCANBENCH_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor)

# scanbench_add_library(NAME name SRCS a.cc b.cc
#                       PUBLIC_LINK_LIBS ... PRIVATE_LINK_LIBS ...)
# Headers are included by their path from the repository root ("solver/image.h").
function(scanbench_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;PUBLIC_LINK_LIBS;PRIVATE_LINK_LIBS" ${ARGN})
  add_library(${ARG_NAME} STATIC ${ARG_SRCS})
  target_include_directories(${ARG_NAME} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${ARG_NAME}
    PUBLIC ${ARG_PUBLIC_LINK_LIBS}
    PRIVATE ${ARG_PRIVATE_LINK_LIBS})
  target_compile_options(${ARG_NAME} PRIVATE ${SCANBENCH_WARNING_FLAGS})
endfunction()

# scanbench_add_executable(NAME name SRCS ... LINK_LIBS ...)
function(scanbench_add_executable)
  cmake_parse_arguments(ARG "" "NAME;OUTPUT_NAME" "SRCS;LINK_LIBS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LINK_LIBS})
  target_compile_options(${ARG_NAME} PRIVATE ${SCANBENCH_WARNING_FLAGS})
  if(ARG_OUTPUT_NAME)
    set_target_properties(${ARG_NAME} PROPERTIES OUTPUT_NAME ${ARG_OUTPUT_NAME})
  endif()
endfunction()

# scanbench_add_test(NAME name SRCS ... LINK_LIBS ...)
# Tests see SCANBENCH_SOURCE_DIR so that they can find ../shared/data.
function(scanbench_add_test)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;LINK_LIBS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LINK_LIBS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_compile_options(${ARG_NAME} PRIVATE ${SCANBENCH_WARNING_FLAGS})
  target_compile_definitions(${ARG_NAME} PRIVATE SCANBENCH_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  gtest_discover_tests(${ARG_NAME} TEST_PREFIX "${ARG_NAME}." DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT 600)
endfunction()

# scanbench_add_benchmark(NAME name SRCS ... LINK_LIBS ...)
function(scanbench_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;LINK_LIBS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LINK_LIBS} benchmark::benchmark benchmark::benchmark_main)
  target_compile_options(${ARG_NAME} PRIVATE ${SCANBENCH_WARNING_FLAGS})
endfunction()
