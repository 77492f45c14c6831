// The Board's hardware outputs for native tests: reply lines into a vector, a RAM EEPROM of
// 1 KB, interrupts a no-op; and a bench that boots a board on them and sends it command lines.
// Shared by test_board.cpp and test_board_preview.cpp.
#pragma once
#include <stdint.h>
#include <string.h>

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

// A board of type B booted on a blank EEPROM (the firmware's defaults), its reply lines kept.
template <class B>
struct BoardTestBench {
  uint8_t ee[1024];
  std::vector<std::string> lines;
  B* b;
  BoardTestBench() {
    memset(ee, 0xFF, sizeof ee);
    b = new B(BoardTestIo{ee, &lines});
    b->boot(false, "# ready");
  }
  ~BoardTestBench() { delete b; }
  BoardTestBench(const BoardTestBench&) = delete;
  BoardTestBench& operator=(const BoardTestBench&) = delete;
  // One line in, byte by byte as the firmware's loop feeds it (a model operation run at the top
  // of the caller's stack, as main() does), its last reply out.
  std::string cmd(const std::string& s) {
    lines.clear();
    for (char c : s + "\n") {
      if (!b->rx(c)) continue;
      b->handle_line();
      if (b->model_pending()) b->run_model_op();
      b->poll();
    }
    return lines.empty() ? "" : lines.back();
  }
};
