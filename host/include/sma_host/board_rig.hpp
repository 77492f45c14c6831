// The rig the host's Board runs (sma sim, the tests): the firmware's constants (rig_config.h via
// rig_board.h: tick, V_max, PWM, ADC, sensor calibration, latch) with every feature, the preview
// and the lead included (the Mega image's set; the Uno's float image lacks only the preview). Needs
// firmware/include on the include path. The virtual rig's --native mode includes rig_board.h
// itself: it is the Uno image's twin.
#ifndef SMA_HOST_BOARD_RIG_HPP
#define SMA_HOST_BOARD_RIG_HPP

#ifndef RIG_FEATURE_PREVIEW
#define RIG_FEATURE_PREVIEW 1
#endif
#include "rig_board.h"

// The console's preview rows in every translation unit of a host binary (console::State's layout).
static_assert(SMA_CONSOLE_PREVIEW == 1 && RIG_FEATURE_PREVIEW == 1, "the host's board has the preview");
// Likewise the lead's row (the known future of inverse + PID).
static_assert(SMA_CONSOLE_LEAD == 1 && RIG_FEATURE_LEAD == 1, "the host's board has the lead");

namespace sma_host {
typedef RigBoard HostRig;
}  // namespace sma_host

#endif  // SMA_HOST_BOARD_RIG_HPP
