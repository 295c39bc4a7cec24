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

# scanbench_isa_variant_sources(STEM stem OUT_SRCS var OUT_VARIANTS var)
# A kernel set compiled once per instruction set and picked at run time
# (solver/cpu_dispatch.h): <stem>_baseline.cc always; on x86-64 with GCC or
# Clang also <stem>_avx2.cc and <stem>_avx512.cc with their -m flags. Sets
# OUT_SRCS to the sources and OUT_VARIANTS to ON when the variants are built
# (the library then defines SCANBENCH_ISA_VARIANTS for its dispatch).
function(scanbench_isa_variant_sources)
  cmake_parse_arguments(ARG "" "STEM;OUT_SRCS;OUT_VARIANTS" "" ${ARGN})
  set(srcs ${ARG_STEM}_baseline.cc)
  set(variants OFF)
  if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    set(variants ON)
    list(APPEND srcs ${ARG_STEM}_avx2.cc ${ARG_STEM}_avx512.cc)
    set_source_files_properties(${ARG_STEM}_avx2.cc PROPERTIES COMPILE_OPTIONS "-mavx2;-mfma")
    set_source_files_properties(${ARG_STEM}_avx512.cc PROPERTIES COMPILE_OPTIONS
      "-mavx2;-mfma;-mavx512f;-mavx512vl;-mavx512bw;-mavx512dq;-mprefer-vector-width=512")
  endif()
  set(${ARG_OUT_SRCS} ${srcs} PARENT_SCOPE)
  set(${ARG_OUT_VARIANTS} ${variants} PARENT_SCOPE)
endfunction()
