// Tiny command-line helpers shared by the host programs.
#ifndef SMA_TOOLS_CLI_HPP
#define SMA_TOOLS_CLI_HPP

#include <cmath>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <vector>
#include "error.hpp"

namespace sma_tools {

class Args {
 public:
  Args(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) a_.push_back(argv[i]);
    for (int i = 0; i < argc; ++i) line_ += (i ? " " : "") + std::string(argv[i]);
  }
  bool empty() const { return pos_ >= a_.size(); }
  std::string next() { return a_[pos_++]; }
  const std::string& peek() const { return a_[pos_]; }
  std::string value(const std::string& opt) {
    if (empty()) throw Error(opt + ": missing value");
    return next();
  }
  double number(const std::string& opt) {
    const std::string s = value(opt);
    char* end = nullptr;
    const double x = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != 0 || !std::isfinite(x)) throw Error(opt + ": '" + s + "' is not a number");
    return x;
  }
  const std::string& command_line() const { return line_; }

 private:
  std::vector<std::string> a_;
  size_t pos_ = 0;
  std::string line_;
};

inline std::vector<std::string> split_names(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= s.size()) {
    const size_t comma = s.find(',', start);
    const std::string item = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!item.empty()) out.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

// main() of a host program: every failure is an exception whose message names the file, line
// and problem; print it as "NAME: error: ..." and exit 1.
template <class Run>
int guarded_main(const char* name, int argc, char** argv, Run run) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << name << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace sma_tools

#endif  // SMA_TOOLS_CLI_HPP
