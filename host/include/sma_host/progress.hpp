// Progress of a long host run (a fit, the discrepancy candidates, a virtual-rig run) as lines
//   progress: <done>/<total> <text>
// on stderr, which `sma` (tools/py/sma/progress.py) turns into a bar with the time left on a
// terminal and a plain line every 10 s in a log. A helper calls its reporter once per step of
// its loop; the call is cheap (one comparison) unless a line is due.
//
// Who sees the lines: `sma` sets SMA_PROGRESS=1 for the helpers it runs; on a terminal the line
// is redrawn in place; otherwise (a test or a script reading stderr) nothing is printed, so the
// helpers' other output stays as it was.
#ifndef SMA_HOST_PROGRESS_HPP
#define SMA_HOST_PROGRESS_HPP

#include <unistd.h>

#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>

namespace sma_host {

class ProgressLine {
 public:
  // `total` 0: silent until a total is given (the 3-argument call).
  explicit ProgressLine(std::string text, double total = 0.0)
      : text_(std::move(text)), total_(total), on_(enabled()), tty_(isatty(2) != 0) {}
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;
  ~ProgressLine() { finish(); }

  // One step of a loop: `done` out of the total. Prints when 1/1000 of the total or more has
  // passed since the last line and at least 0.5 s (0.1 s on a terminal) have.
  void operator()(double done) {
    done_ = done;
    if (!on_ || done < next_ || total_ <= 0) return;
    next_ = done + total_ / 1000.0;
    const double now = seconds();
    if (now - last_ < (tty_ ? 0.1 : 0.5)) return;
    last_ = now;
    print(false);
  }
  // A new bar: another total and text (a new phase of the run), `done` of it so far.
  void operator()(double done, double total, const std::string& text) {
    total_ = total;
    text_ = text;
    next_ = 0;
    last_ = -1e18;
    finished_ = false;
    (*this)(done);
  }
  // One more job done (thread safe: jobs finish on several threads).
  void tick() {
    std::lock_guard<std::mutex> lock(mutex_);
    (*this)(done_ + 1.0);
  }
  double done() const { return done_; }
  double total() const { return total_; }
  // The last line (the bar's end); called by the destructor, once.
  void finish() {
    if (!on_ || finished_) return;
    finished_ = true;
    if (last_ > -1e9 && (tty_ || done_ != printed_)) print(true);
  }

  static bool enabled() {
    const char* e = std::getenv("SMA_PROGRESS");
    if (e && *e) return std::strcmp(e, "0") != 0;
    return isatty(2) != 0;
  }

 private:
  static double seconds() {
    using namespace std::chrono;
    return duration<double>(steady_clock::now().time_since_epoch()).count();
  }
  void print(bool last) {
    printed_ = done_;
    std::fprintf(stderr, "%sprogress: %.6g/%.6g %s%s", tty_ ? "\r\x1b[K" : "", done_, total_, text_.c_str(),
                 tty_ && !last ? "" : "\n");
    std::fflush(stderr);
  }

  std::string text_;
  double total_;
  double done_ = 0, next_ = 0, last_ = -1e18, printed_ = -1;
  bool on_, tty_, finished_ = false;
  std::mutex mutex_;
};

// Rounds of independent jobs where each round has one job fewer than the last: the discrepancy
// workflow's greedy selection (every round either adds its winner to the model or sets it aside,
// discrepancy.hpp), `first` candidates in round 1. One bar per round.
class RoundsProgress {
 public:
  RoundsProgress(const char* what, double first) : what_(what), size_(first), line_(label(what, 1), first) {}
  // One job of the current round done (thread safe).
  void tick() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (line_.done() >= size_) {  // the round was complete: this job opens the next one
      line_.finish();
      ++round_;
      size_ -= 1.0;
      line_(0.0, size_, label(what_, round_));
    }
    line_.tick();
  }
  void finish() { line_.finish(); }

 private:
  static std::string label(const char* what, int round) { return std::string(what) + ", round " + std::to_string(round); }
  const char* what_;
  double size_;
  int round_ = 1;
  ProgressLine line_;
  std::mutex mutex_;
};


// A benchmark's "[k/N] case" line on stderr: redrawn in place on a terminal, one plain line per
// case in a log (a CI log would otherwise hold every case on one carriage-return line).
class CaseLine {
 public:
  CaseLine() : tty_(isatty(2) != 0) {}
  CaseLine(const CaseLine&) = delete;
  CaseLine& operator=(const CaseLine&) = delete;
  ~CaseLine() { finish(); }
  void operator()(const char* fmt, ...) __attribute__((format(printf, 2, 3))) {
    std::va_list args;
    va_start(args, fmt);
    if (tty_) std::fputs("\r\x1b[K", stderr);
    std::vfprintf(stderr, fmt, args);
    va_end(args);
    if (!tty_) std::fputc('\n', stderr);
    std::fflush(stderr);
    open_ = tty_;
  }
  // Ends the terminal's redrawn line (nothing to do in a log).
  void finish() {
    if (open_) std::fputc('\n', stderr);
    open_ = false;
  }

 private:
  bool tty_;
  bool open_ = false;
};

}  // namespace sma_host

#endif  // SMA_HOST_PROGRESS_HPP
