// The host tools read rig logs with the engine's reader (sma_host/rig_log.hpp): one RigLog type.
#ifndef SMA_TOOLS_RIG_LOG_HPP
#define SMA_TOOLS_RIG_LOG_HPP

#include "error.hpp"
#include "../../../../host/include/sma_host/rig_log.hpp"  // relative: see error.hpp

namespace sma_tools {
using sma_host::RigLog;
using sma_host::LogReadOptions;
using sma_host::parse_rig_log;
using sma_host::read_rig_log;
using sma_host::describe_problems;
using sma_host::dropped_note;
namespace detail {
using sma_host::detail::trim;
using sma_host::detail::split;
using sma_host::detail::to_number;
}  // namespace detail
}  // namespace sma_tools

#endif  // SMA_TOOLS_RIG_LOG_HPP
