// libFuzzer target: the rig-log CSV reader (tools/host/include/sma_tools/rig_log.hpp) on
// arbitrary bytes. It must return a RigLog or throw sma_tools::Error: any other exception, a
// crash, a hang or a leak is a bug. On success the result must be consistent:
//   * at least min_rows rows; t, v, d, line of the same length; ref/duty/f empty or that length;
//   * every value finite; t strictly increasing; file lines strictly increasing;
//   * rows_read == kept + dropped; dropped within the allowed fraction and count;
//   * the problems list is bounded; describe_problems()/dropped_note() do not throw.
// Byte 0 selects the read options (min_rows, max_bad_fraction, max_bad_rows, keep_problems).
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmath>
#include <sstream>
#include <string>

#include "sma_tools/rig_log.hpp"

namespace {
[[noreturn]] void fail(const char* what) {
  fprintf(stderr, "fuzz_rig_log: invariant violated: %s\n", what);
  abort();
}
#define CHECK(c, what) \
  do {                 \
    if (!(c)) fail(what); \
  } while (0)

bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  sma_tools::LogReadOptions opt;
  const uint8_t o = data[0];
  opt.min_rows = o & 3;
  opt.max_bad_fraction = ((o >> 2) & 3) * 0.25;  // 0, 0.25, 0.5, 0.75
  opt.max_bad_rows = (o & 0x10) ? 3 : 1000;
  opt.keep_problems = (o & 0x20) ? 0 : 10;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  std::istringstream in(text);
  sma_tools::RigLog log;
  try {
    log = sma_tools::parse_rig_log(in, "fuzz.csv", opt);
  } catch (const sma_tools::Error& e) {
    CHECK(std::string(e.what()).compare(0, 8, "fuzz.csv") == 0, "error message does not name the file");
    return 0;
  }
  const size_t n = log.size();
  CHECK(n >= opt.min_rows, "fewer rows than min_rows");
  CHECK(log.v.size() == n && log.d.size() == n && log.line.size() == n, "column lengths differ");
  CHECK(log.ref.empty() || log.ref.size() == n, "ref length");
  CHECK(log.duty.empty() || log.duty.size() == n, "duty length");
  CHECK(log.f.empty() || log.f.size() == n, "f length");
  CHECK(all_finite(log.t) && all_finite(log.v) && all_finite(log.d) && all_finite(log.ref) &&
            all_finite(log.duty) && all_finite(log.f),
        "a non-finite value was kept");
  for (size_t i = 1; i < n; ++i) {
    CHECK(log.t[i] > log.t[i - 1], "time does not increase");
    CHECK(log.line[i] > log.line[i - 1], "line numbers do not increase");
  }
  CHECK(log.rows_read == static_cast<long>(n) + log.dropped, "rows_read != kept + dropped");
  CHECK(log.dropped <= opt.max_bad_rows, "more bad rows than max_bad_rows accepted");
  if (log.rows_read > 0)
    CHECK(static_cast<double>(log.dropped) / static_cast<double>(log.rows_read) <= opt.max_bad_fraction,
          "more than max_bad_fraction bad rows accepted");
  CHECK(log.problems.size() <= 1000 && log.problems.size() <= static_cast<size_t>(log.dropped),
        "problems list too long");
  CHECK(std::isfinite(log.duration()) && log.duration() >= 0.0, "duration");
#ifdef SMA_FUZZ_STRICT
  // Strict numbers: every kept field of t_s, v_V, d_mm is a plain decimal ([+-] digits [.digits]
  // [e[+-]digits]), not a hex float such as 0x1p3 that strtod() also reads. Off by default: the
  // reader accepts hex today (test/fuzz/repro/rig_log_hex.csv).
  {
    std::vector<std::string> lines;
    std::istringstream again(text);
    std::string ln;
    while (std::getline(again, ln)) lines.push_back(ln);
    std::vector<int> idx;
    for (const char* want : {"t_s", "v_V", "d_mm"})
      for (size_t c = 0; c < log.columns.size(); ++c)
        if (log.columns[c] == want) idx.push_back(static_cast<int>(c));
    for (long l : log.line) {
      const std::vector<std::string> f = sma_tools::detail::split(sma_tools::detail::trim(lines[static_cast<size_t>(l - 1)]));
      for (int c : idx)
        CHECK(f[static_cast<size_t>(c)].find_first_not_of("0123456789+-.eE") == std::string::npos,
              "a field that is not a plain decimal was read as a number");
    }
  }
#endif
  (void)sma_tools::describe_problems(log, opt.keep_problems);
  (void)sma_tools::dropped_note(log);
  return 0;
}
