// Rig log CSV (interfaces.md): a header line with at least t_s, v_V, d_mm; optional ref_mm, duty,
// f_N; unknown columns ignored; '#' lines are comments. Strict: a row with a missing or extra
// field, text where a number belongs, NaN/inf, or a time that does not increase is reported with
// its line number and dropped; a file with more bad rows than allowed is refused. Nothing is
// ever silently misread.
#ifndef SMA_HOST_RIG_LOG_HPP
#define SMA_HOST_RIG_LOG_HPP

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <sstream>
#include <string>
#include <vector>
#include "error.hpp"

namespace sma_host {

struct RigLog {
  std::string name;                   // file name, for messages
  std::vector<std::string> comments;  // '#' lines, without the '#'
  std::vector<std::string> columns;   // header as in the file
  std::vector<std::string> ignored;   // unknown columns
  std::vector<double> t, v, d, ref, duty, f;  // optional ones empty when absent
  std::vector<long> line;             // file line of each kept row
  long rows_read = 0;                 // data rows seen
  long dropped = 0;                   // bad rows dropped
  std::vector<std::string> problems;  // "name:line: problem" of the first bad rows
  // Several runs joined into one (identify.hpp: concatenate): the rows where runs 2.. start,
  // and each run's file name. Empty: one run.
  std::vector<size_t> run_starts;
  std::vector<std::string> run_names;
  bool has_ref() const { return !ref.empty(); }
  bool has_duty() const { return !duty.empty(); }
  bool has_f() const { return !f.empty(); }
  size_t size() const { return t.size(); }
  double duration() const { return t.empty() ? 0.0 : t.back() - t.front(); }
  // Median sampling period (robust to a few dropped rows), s.
  double sample_period() const {
    std::vector<double> dt;
    for (size_t k = 1; k < t.size(); ++k) dt.push_back(t[k] - t[k - 1]);
    if (dt.empty()) return 0.0;
    std::nth_element(dt.begin(), dt.begin() + static_cast<long>(dt.size() / 2), dt.end());
    return dt[dt.size() / 2];
  }
};

struct LogReadOptions {
  double max_bad_fraction = 0.01;  // refuse when more than this fraction of the rows is bad
  long max_bad_rows = 1000;        // ... or more than this many
  size_t min_rows = 2;
  size_t keep_problems = 10;       // problems listed in messages
};

namespace detail {

inline std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && (s[a] == ' ' || s[a] == '\t' || s[a] == '\r')) ++a;
  while (b > a && (s[b - 1] == ' ' || s[b - 1] == '\t' || s[b - 1] == '\r')) --b;
  return s.substr(a, b - a);
}

inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  for (;;) {
    const size_t comma = s.find(',', start);
    out.push_back(trim(s.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

// A finite decimal number filling the whole field.
// A plain decimal: [+-]digits[.digits][(e|E)[+-]digits] (no hex floats, no inf/nan, no leading
// whitespace of any kind: strtod alone would take "0x1p3" as 8, found by fuzz_rig_log).
inline bool to_number(const std::string& s, double& x) {
  size_t i = 0;
  auto digits = [&]() {
    const size_t start = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    return i - start;
  };
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  size_t n = digits();
  if (i < s.size() && s[i] == '.') {
    ++i;
    n += digits();
  }
  if (n == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  if (i != s.size()) return false;
  char* end = nullptr;
  x = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(x);
}

}  // namespace detail

inline std::string describe_problems(const RigLog& log, size_t keep) {
  std::string out;
  const size_t shown = log.problems.size() < keep ? log.problems.size() : keep;
  for (size_t i = 0; i < shown; ++i) out += "\n  " + log.problems[i];
  const long more = log.dropped - static_cast<long>(shown);
  if (more > 0) out += "\n  ... and " + std::to_string(more) + " more";
  return out;
}

inline RigLog parse_rig_log(std::istream& in, const std::string& name,
                            const LogReadOptions& opt = LogReadOptions()) {
  RigLog log;
  log.name = name;
  std::string raw;
  long lineno = 0;
  int ci_t = -1, ci_v = -1, ci_d = -1, ci_ref = -1, ci_duty = -1, ci_f = -1;
  size_t ncol = 0;
  bool have_header = false;
  auto bad = [&](const std::string& msg) {
    ++log.dropped;
    if (log.problems.size() < 1000) log.problems.push_back(name + ":" + std::to_string(lineno) + ": " + msg);
  };
  while (std::getline(in, raw)) {
    ++lineno;
    // A UTF-8 byte-order mark (spreadsheet exports) before the first line is not data.
    if (lineno == 1 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
    const std::string s = detail::trim(raw);
    if (s.empty()) continue;
    if (s[0] == '#') {
      log.comments.push_back(detail::trim(s.substr(1)));
      continue;
    }
    if (!have_header) {
      have_header = true;
      log.columns = detail::split(s);
      ncol = log.columns.size();
      for (size_t i = 0; i < ncol; ++i) {
        const std::string& c = log.columns[i];
        int* slot = c == "t_s" ? &ci_t : c == "v_V" ? &ci_v : c == "d_mm" ? &ci_d
                  : c == "ref_mm" ? &ci_ref : c == "duty" ? &ci_duty : c == "f_N" ? &ci_f : nullptr;
        if (!slot) {
          log.ignored.push_back(c);
          continue;
        }
        if (*slot >= 0)
          throw Error(name + ":" + std::to_string(lineno) + ": column '" + c + "' appears twice");
        *slot = static_cast<int>(i);
      }
      const char* req[] = {"t_s", "v_V", "d_mm"};
      const int idx[] = {ci_t, ci_v, ci_d};
      for (int r = 0; r < 3; ++r)
        if (idx[r] < 0)
          throw Error(name + ":" + std::to_string(lineno) + ": header has no column '" + req[r] +
                      "' (a rig log needs t_s,v_V,d_mm; the header read was: " + s + ")");
      continue;
    }
    ++log.rows_read;
    const std::vector<std::string> fields = detail::split(s);
    if (fields.size() != ncol) {
      bad(std::to_string(fields.size()) + " fields, the header has " + std::to_string(ncol));
      continue;
    }
    double val[6] = {0, 0, 0, 0, 0, 0};
    const int idx[6] = {ci_t, ci_v, ci_d, ci_ref, ci_duty, ci_f};
    bool ok = true;
    for (int k = 0; k < 6 && ok; ++k) {
      if (idx[k] < 0) continue;
      const std::string& fld = fields[static_cast<size_t>(idx[k])];
      if (!detail::to_number(fld, val[k])) {
        bad("column '" + log.columns[static_cast<size_t>(idx[k])] + "': '" + fld.substr(0, 20) +
            "' is not a finite number");
        ok = false;
      }
    }
    if (!ok) continue;
    if (!log.t.empty() && !(val[0] > log.t.back())) {
      bad("time t_s=" + fields[static_cast<size_t>(ci_t)] + " does not increase (previous " +
          std::to_string(log.t.back()) + " at line " + std::to_string(log.line.back()) + ")");
      continue;
    }
    log.t.push_back(val[0]);
    log.v.push_back(val[1]);
    log.d.push_back(val[2]);
    if (ci_ref >= 0) log.ref.push_back(val[3]);
    if (ci_duty >= 0) log.duty.push_back(val[4]);
    if (ci_f >= 0) log.f.push_back(val[5]);
    log.line.push_back(lineno);
  }
  if (!have_header) throw Error(name + ": no header line (expected t_s,v_V,d_mm,...)");
  const double frac = log.rows_read ? static_cast<double>(log.dropped) / static_cast<double>(log.rows_read) : 0.0;
  if (log.dropped > 0 && (frac > opt.max_bad_fraction || log.dropped > opt.max_bad_rows))
    throw Error(name + ": refused: " + std::to_string(log.dropped) + " bad rows of " +
                std::to_string(log.rows_read) + " (more than " +
                std::to_string(static_cast<int>(opt.max_bad_fraction * 100.0 + 0.5)) + " %):" +
                describe_problems(log, opt.keep_problems));
  if (log.size() < opt.min_rows)
    throw Error(name + ": only " + std::to_string(log.size()) + " valid rows (need at least " +
                std::to_string(opt.min_rows) + ")");
  return log;
}

inline RigLog read_rig_log(const std::string& path, const LogReadOptions& opt = LogReadOptions()) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  return parse_rig_log(f, path, opt);
}

// One line for stderr when rows were dropped ("" if none).
inline std::string dropped_note(const RigLog& log, size_t keep = 5) {
  if (log.dropped == 0) return "";
  return log.name + ": dropped " + std::to_string(log.dropped) + " bad rows of " +
         std::to_string(log.rows_read) + ":" + describe_problems(log, keep);
}

}  // namespace sma_host

#endif  // SMA_HOST_RIG_LOG_HPP
