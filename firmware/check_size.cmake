# Fails the build when a firmware image does not fit the Uno: flash (.text + .data) must leave
# the 512-B Optiboot bootloader alone (32256 B), and static RAM (.data + .bss) must leave room
# for the stack (the FIL tests measure the deepest stack, ~400 B). Called after each link with
#   cmake -DAVR_SIZE=... -DELF=... -P check_size.cmake
execute_process(COMMAND ${AVR_SIZE} ${ELF} OUTPUT_VARIABLE out RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "avr-size failed on ${ELF}")
endif()
string(REGEX MATCH "\n *([0-9]+)[ \t]+([0-9]+)[ \t]+([0-9]+)" _ "${out}")
math(EXPR flash "${CMAKE_MATCH_1} + ${CMAKE_MATCH_2}")
math(EXPR ram "${CMAKE_MATCH_2} + ${CMAKE_MATCH_3}")
set(flash_max 32256)
set(ram_max 1700)
math(EXPR flash_free "${flash_max} - ${flash}")
message(STATUS "${ELF}: flash ${flash} of ${flash_max} B (${flash_free} free), static RAM ${ram} of 2048 B")
if(flash GREATER flash_max)
  message(FATAL_ERROR "${ELF}: ${flash} B of flash do not fit the Uno's ${flash_max} B (Optiboot)")
endif()
if(ram GREATER ram_max)
  message(FATAL_ERROR "${ELF}: ${ram} B of static RAM leave less than 348 B for the stack")
endif()
