// The one exception type of the host tools: a message meant for the user, already naming the
// file (and line) and the problem. main() prints it and exits non-zero.
#ifndef SMA_TOOLS_ERROR_HPP
#define SMA_TOOLS_ERROR_HPP

#include <stdexcept>
#include <string>

namespace sma_tools {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace sma_tools

#endif  // SMA_TOOLS_ERROR_HPP
