// Bytes in, complete lines out.
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_LINE_BUFFER_HPP
#define SMA_CONSOLE_LINE_BUFFER_HPP

#include "state.hpp"

namespace sma {
namespace console {

// ---- line assembly -----------------------------------------------------------------------------
// Bytes in, complete lines out. A line ends at '\n' or '\r' ("\r\n" gives one line: the empty
// line between them is ignored). An over-long line, or one with a NUL or a byte >= 128, is
// reported once, at its end, as `overflow` / `binary`, and its bytes are dropped.
class LineBuffer {
 public:
  enum class Status : uint8_t { Pending, Line, TooLong, Binary };

  Status push(char c) {
    if (c == '\n' || c == '\r') {
      const Status s = too_long_ ? Status::TooLong : (binary_ ? Status::Binary : Status::Line);
      const bool empty = len_ == 0 && !too_long_ && !binary_;
      buf_[len_] = 0;
      done_len_ = len_;
      len_ = 0;
      too_long_ = false;
      binary_ = false;
      if (empty && last_was_cr_ && c == '\n') {
        last_was_cr_ = false;
        return Status::Pending;  // the \n of \r\n
      }
      last_was_cr_ = c == '\r';
      return s;
    }
    last_was_cr_ = false;
    const uint8_t u = static_cast<uint8_t>(c);
    if (u == 0 || u >= 128) binary_ = true;
    if (len_ >= kLineMax) {
      too_long_ = true;
      return Status::Pending;
    }
    buf_[len_] = c;
    len_ = static_cast<uint8_t>(len_ + 1);
    return Status::Pending;
  }
  // The completed line (valid after push() returned Line, until the next push()).
  const char* line() const { return buf_; }
  uint8_t length() const { return done_len_; }

 private:
  // Not zeroed at construction (48 stores of flash on AVR): line() is read only after a Line,
  // which 0-terminates it.
  char buf_[kLineMax + 1];
  uint8_t len_ = 0, done_len_ = 0;
  bool too_long_ = false, binary_ = false, last_was_cr_ = false;
};

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_LINE_BUFFER_HPP
