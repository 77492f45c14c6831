# CTest driver for the AVR math benchmark: runs the host fingerprint (sweep_host), then the AVR
# benchmark in simavr with --expect-hash, so the test fails if the AVR assembly disagrees with the
# portable C (self-check) or if any Fixed result differs between the host and the AVR.
# Usage: cmake -DHOST=<sweep_host> -DCYCLES=<avr_math_cycles> -DELF=<elf> -DJSON=<file> -P check.cmake
execute_process(COMMAND ${HOST} OUTPUT_VARIABLE hash OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR hash STREQUAL "")
  message(FATAL_ERROR "sweep_host failed (${rc})")
endif()
execute_process(COMMAND ${CYCLES} ${ELF} --json ${JSON} --expect-hash ${hash} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "avr_math_cycles failed (${rc})")
endif()
