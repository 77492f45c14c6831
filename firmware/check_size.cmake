# Fails the build when a firmware image does not fit the Uno: flash (.text + .data) must leave
# the 512-B Optiboot bootloader alone (32256 B), and static RAM (.data + .bss) must leave room
# for the stack (the FIL tests measure the deepest stack, ~400 B). Called after each link with
#   cmake -DAVR_SIZE=... -DELF=... [-DIMAGE=sma_firmware -DRATCHET=bench/budgets_ratchet.json] -P check_size.cmake
# With IMAGE and RATCHET it also enforces issue 12's budgets (flash <= 28672 B, static RAM <= 1536
# B): a figure whose ratchet meets its budget must stay within it (a met budget is a hard limit),
# one still over it must not exceed its ratchet (today's value, bench/budgets.py --update-ratchet
# tightens it).
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

# Issue 12's budgets, with the ratchet for a figure not met yet (bench/budgets.py reads the same file).
if(IMAGE AND RATCHET AND CMAKE_VERSION VERSION_LESS 3.19)
  message(WARNING "CMake ${CMAKE_VERSION} < 3.19 cannot read ${RATCHET}: issue 12's budgets not enforced at link")
elseif(IMAGE AND RATCHET AND EXISTS ${RATCHET})
  file(READ ${RATCHET} ratchet_json)
  foreach(fig flash_B static_ram_B)
    if(fig STREQUAL "flash_B")
      set(value ${flash})
      set(budget 28672)
    else()
      set(value ${ram})
      set(budget 1536)
    endif()
    if(value GREATER budget)
      string(JSON limit ERROR_VARIABLE no_limit GET "${ratchet_json}" ${IMAGE} ${fig})
      if(no_limit)
        message(FATAL_ERROR "${ELF}: ${fig} ${value} over budget (${budget}, issue 12) and no ratchet in ${RATCHET}")
      elseif(NOT limit GREATER budget)
        message(FATAL_ERROR "${ELF}: ${fig} ${value} breaks its budget ${budget} (issue 12), met before (${limit}, ${RATCHET})")
      elseif(value GREATER limit)
        message(FATAL_ERROR "${ELF}: ${fig} ${value} worse than its ratchet ${limit} (budget ${budget}, issue 12; ${RATCHET})")
      else()
        message(STATUS "${ELF}: ${fig} ${value}: over budget (issue 12): budget ${budget}, ratchet ${limit}")
      endif()
    endif()
  endforeach()
endif()
