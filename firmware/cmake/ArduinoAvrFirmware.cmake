# Builds an Arduino Uno sketch with avr-gcc inside the host build, without a
# second CMake project: every source becomes one custom command (with a
# depfile, so header edits rebuild), the Arduino core becomes an archive as
# the Arduino IDE makes it, and the link reports flash and RAM use.
#
#   scanbench_add_avr_firmware(NAME name SOURCES a.cc b.cc INCLUDE_DIRS dir...)
#
# creates target <name> (in ALL) producing <name>.elf and <name>.hex in the
# current binary folder; the target's FIRMWARE_ELF / FIRMWARE_HEX properties
# hold their paths.

set(SCANBENCH_ARDUINO_AVR_DIR "/usr/share/arduino/hardware/arduino/avr" CACHE PATH
    "Arduino AVR core (Debian package arduino-core-avr)")
set(SCANBENCH_AVR_MCU "atmega328p" CACHE STRING "AVR part of the LED board (Arduino Uno)")
set(SCANBENCH_AVR_F_CPU "16000000" CACHE STRING "LED board clock, Hz (Arduino Uno: 16 MHz crystal)")
# Uno limits: flash less the 512-byte optiboot bootloader, and the SRAM.
set(SCANBENCH_AVR_FLASH_BYTES 32256)
set(SCANBENCH_AVR_RAM_BYTES 2048)

find_program(SCANBENCH_AVR_GCC avr-gcc)
find_program(SCANBENCH_AVR_GXX avr-g++)
find_program(SCANBENCH_AVR_AR avr-ar)
find_program(SCANBENCH_AVR_OBJCOPY avr-objcopy)
find_program(SCANBENCH_AVR_SIZE avr-size)
foreach(tool SCANBENCH_AVR_GCC SCANBENCH_AVR_GXX SCANBENCH_AVR_AR SCANBENCH_AVR_OBJCOPY SCANBENCH_AVR_SIZE)
  if(NOT ${tool})
    message(FATAL_ERROR "${tool}: the AVR toolchain is missing (Debian packages gcc-avr, binutils-avr, "
                        "avr-libc); run scripts/install-deps.sh")
  endif()
endforeach()
if(NOT EXISTS "${SCANBENCH_ARDUINO_AVR_DIR}/cores/arduino/Arduino.h")
  message(FATAL_ERROR "SCANBENCH_ARDUINO_AVR_DIR=${SCANBENCH_ARDUINO_AVR_DIR} holds no cores/arduino/Arduino.h: "
                      "install arduino-core-avr (scripts/install-deps.sh) or point the variable at an Arduino AVR core")
endif()

set(_scanbench_avr_core_dir "${SCANBENCH_ARDUINO_AVR_DIR}/cores/arduino")
set(_scanbench_avr_variant_dir "${SCANBENCH_ARDUINO_AVR_DIR}/variants/standard")
set(_scanbench_avr_common_flags
  -mmcu=${SCANBENCH_AVR_MCU} -DF_CPU=${SCANBENCH_AVR_F_CPU}L
  -DARDUINO=10807 -DARDUINO_AVR_UNO -DARDUINO_ARCH_AVR
  -Os -g -ffunction-sections -fdata-sections
  -I${_scanbench_avr_core_dir} -I${_scanbench_avr_variant_dir})
set(_scanbench_avr_c_flags -std=gnu11)
set(_scanbench_avr_cxx_flags -std=gnu++11 -fno-exceptions -fno-threadsafe-statics -fno-rtti)
# The core is third-party code written for the IDE's -w; Debian's WString.cpp
# needs DECIMAL_DIG, which avr-gcc 5.4's float.h lacks.
set(_scanbench_avr_core_flags -w -DDECIMAL_DIG=__DECIMAL_DIG__)
set(_scanbench_avr_own_flags -Wall -Wextra -Wpedantic -Wshadow -Werror)

# One object from one source; the launcher (ccache) applies as for host code.
function(_scanbench_avr_compile source object extra_flags)
  get_filename_component(extension "${source}" LAST_EXT)
  if(extension STREQUAL ".c")
    set(compiler ${SCANBENCH_AVR_GCC})
    set(language_flags ${_scanbench_avr_c_flags})
  elseif(extension STREQUAL ".S")
    set(compiler ${SCANBENCH_AVR_GCC})
    set(language_flags -x assembler-with-cpp)
  else()
    set(compiler ${SCANBENCH_AVR_GXX})
    set(language_flags -x c++ ${_scanbench_avr_cxx_flags})
  endif()
  get_filename_component(object_dir "${object}" DIRECTORY)
  file(MAKE_DIRECTORY "${object_dir}")
  add_custom_command(OUTPUT "${object}"
    COMMAND ${CCACHE_PROGRAM} ${compiler} ${_scanbench_avr_common_flags} ${language_flags} ${extra_flags}
            -MD -MF "${object}.d" -MT "${object}" -c "${source}" -o "${object}"
    DEPENDS "${source}"
    DEPFILE "${object}.d"
    COMMENT "avr-gcc ${source}"
    VERBATIM)
endfunction()

function(scanbench_add_avr_firmware)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;INCLUDE_DIRS" ${ARGN})
  set(work_dir "${CMAKE_CURRENT_BINARY_DIR}/${ARG_NAME}.avr")

  # The whole core, as the IDE builds it; the linker keeps what is used.
  file(GLOB core_sources CONFIGURE_DEPENDS
    "${_scanbench_avr_core_dir}/*.c" "${_scanbench_avr_core_dir}/*.cpp" "${_scanbench_avr_core_dir}/*.S")
  set(core_objects "")
  foreach(source IN LISTS core_sources)
    get_filename_component(file_name "${source}" NAME)
    set(object "${work_dir}/core/${file_name}.o")
    _scanbench_avr_compile("${source}" "${object}" "${_scanbench_avr_core_flags}")
    list(APPEND core_objects "${object}")
  endforeach()
  set(core_archive "${work_dir}/arduino_core.a")
  add_custom_command(OUTPUT "${core_archive}"
    COMMAND ${CMAKE_COMMAND} -E rm -f "${core_archive}"
    COMMAND ${SCANBENCH_AVR_AR} rcs "${core_archive}" ${core_objects}
    DEPENDS ${core_objects}
    COMMENT "avr-ar Arduino core"
    VERBATIM)

  set(own_flags ${_scanbench_avr_own_flags})
  foreach(dir IN LISTS ARG_INCLUDE_DIRS)
    list(APPEND own_flags "-I${dir}")
  endforeach()
  set(own_objects "")
  foreach(source IN LISTS ARG_SOURCES)
    get_filename_component(source "${source}" ABSOLUTE)
    file(RELATIVE_PATH relative "${PROJECT_SOURCE_DIR}" "${source}")
    set(object "${work_dir}/own/${relative}.o")
    _scanbench_avr_compile("${source}" "${object}" "${own_flags}")
    list(APPEND own_objects "${object}")
  endforeach()

  set(elf "${CMAKE_CURRENT_BINARY_DIR}/${ARG_NAME}.elf")
  set(hex "${CMAKE_CURRENT_BINARY_DIR}/${ARG_NAME}.hex")
  set(size_report "${CMAKE_CURRENT_BINARY_DIR}/${ARG_NAME}.size.txt")
  add_custom_command(OUTPUT "${elf}"
    COMMAND ${SCANBENCH_AVR_GCC} -mmcu=${SCANBENCH_AVR_MCU} -Os -Wl,--gc-sections
            -o "${elf}" ${own_objects} "${core_archive}" -lm
    DEPENDS ${own_objects} "${core_archive}"
    COMMENT "avr-gcc link ${ARG_NAME}.elf"
    VERBATIM)
  add_custom_command(OUTPUT "${hex}"
    COMMAND ${SCANBENCH_AVR_OBJCOPY} -O ihex -R .eeprom "${elf}" "${hex}"
    DEPENDS "${elf}"
    COMMENT "avr-objcopy ${ARG_NAME}.hex"
    VERBATIM)
  # Printed on every relink, and fails the build when the Uno is too small.
  add_custom_command(OUTPUT "${size_report}"
    COMMAND ${CMAKE_COMMAND} -DAVR_SIZE=${SCANBENCH_AVR_SIZE} -DELF=${elf} -DREPORT=${size_report}
            -DFLASH_BYTES=${SCANBENCH_AVR_FLASH_BYTES} -DRAM_BYTES=${SCANBENCH_AVR_RAM_BYTES}
            -P "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/ReportFirmwareSize.cmake"
    DEPENDS "${elf}" "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/ReportFirmwareSize.cmake"
    VERBATIM)
  add_custom_target(${ARG_NAME} ALL DEPENDS "${elf}" "${hex}" "${size_report}")
  set_target_properties(${ARG_NAME} PROPERTIES FIRMWARE_ELF "${elf}" FIRMWARE_HEX "${hex}")
endfunction()
