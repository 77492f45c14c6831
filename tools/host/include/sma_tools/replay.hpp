// The host tools run the model with the engine's replay (sma_host/identify.hpp): one
// initial-state rule for sim, fit and discrepancy.
#ifndef SMA_TOOLS_REPLAY_HPP
#define SMA_TOOLS_REPLAY_HPP

#include "params_json.hpp"
#include "sma_host/identify.hpp"

namespace sma_tools {
using sma_host::ReplayOptions;
using sma_host::Trace;
using sma_host::replay;
}  // namespace sma_tools

#endif  // SMA_TOOLS_REPLAY_HPP
