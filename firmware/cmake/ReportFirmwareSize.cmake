# cmake -DAVR_SIZE=avr-size -DELF=x.elf -DREPORT=x.size.txt -DFLASH_BYTES=n -DRAM_BYTES=n -P ReportFirmwareSize.cmake
# Flash = .text + .data (initial values live in flash); RAM = .data + .bss,
# before the stack, which needs what is left.
execute_process(COMMAND ${AVR_SIZE} --format=berkeley "${ELF}"
  OUTPUT_VARIABLE output RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${AVR_SIZE} failed on ${ELF}")
endif()
string(REGEX MATCH "\n[ \t]*([0-9]+)[ \t]+([0-9]+)[ \t]+([0-9]+)" row "${output}")
set(text ${CMAKE_MATCH_1})
set(data ${CMAKE_MATCH_2})
set(bss ${CMAKE_MATCH_3})
math(EXPR flash "${text} + ${data}")
math(EXPR ram "${data} + ${bss}")
math(EXPR flash_percent "100 * ${flash} / ${FLASH_BYTES}")
math(EXPR ram_percent "100 * ${ram} / ${RAM_BYTES}")
get_filename_component(name "${ELF}" NAME)
set(line "${name}: flash ${flash} of ${FLASH_BYTES} bytes (${flash_percent}%), RAM ${ram} of ${RAM_BYTES} bytes (${ram_percent}%, stack not counted)")
message(STATUS "${line}")
file(WRITE "${REPORT}" "${line}\n")
if(flash GREATER FLASH_BYTES OR ram GREATER RAM_BYTES)
  file(REMOVE "${REPORT}")
  message(FATAL_ERROR "${name} does not fit an Arduino Uno: ${line}")
endif()
