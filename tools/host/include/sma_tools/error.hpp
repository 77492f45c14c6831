// The host tools' exception type is the engine's (sma_host/error.hpp).
#ifndef SMA_TOOLS_ERROR_HPP
#define SMA_TOOLS_ERROR_HPP

// Relative: the vrig and fuzz targets compile the readers with only this include directory.
#include "../../../../host/include/sma_host/error.hpp"

namespace sma_tools {
using sma_host::Error;
}  // namespace sma_tools

#endif  // SMA_TOOLS_ERROR_HPP
