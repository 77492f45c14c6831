// The one exception type of the host tools and the identification engine: a message meant for the user, already naming the
// file (and line) and the problem. main() prints it and exits non-zero.
#ifndef SMA_HOST_ERROR_HPP
#define SMA_HOST_ERROR_HPP

#include <stdexcept>
#include <string>

namespace sma_host {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace sma_host

#endif  // SMA_HOST_ERROR_HPP
