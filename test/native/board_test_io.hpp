// The Board's hardware outputs for native tests: reply lines into a vector, a RAM EEPROM of
// 1 KB, interrupts a no-op. Shared by test_board.cpp and test_board_preview.cpp.
#pragma once
#include <stdint.h>

#include <string>
#include <vector>

struct BoardTestIo {
  uint8_t* ee;
  std::vector<std::string>* lines;
  bool line(const char* s, uint8_t len) {
    lines->push_back(std::string(s, len));
    return true;
  }
  uint8_t read(uint16_t a) const { return ee[a % 1024]; }
  void write(uint16_t a, uint8_t v) { ee[a % 1024] = v; }
  uint8_t irq_off() { return 0; }
  void irq_restore(uint8_t) {}
};
