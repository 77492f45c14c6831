// rig_config.h as the constants sma::Board (sma/board.hpp) reads: the one source of the rig's
// numbers for the firmware, the virtual rig's native mode, the fuzzer and the host tests.
// Features (all in the one image by default): the model store in EEPROM (pbegin..pinfo), the
// training run (train), the sensor compensation (calibration undone, lag/delay predicted);
// the preview controller only where RIG_FEATURE_PREVIEW is 1, the lead where RIG_FEATURE_LEAD is.
#ifndef RIG_BOARD_H
#define RIG_BOARD_H

#include "rig_config.h"

#ifndef RIG_FEATURE_MODEL
#define RIG_FEATURE_MODEL 1
#endif
#ifndef RIG_FEATURE_TRAIN
#define RIG_FEATURE_TRAIN 1
#endif
#ifndef RIG_FEATURE_COMPENSATE
#define RIG_FEATURE_COMPENSATE 1
#endif
// The preview controller (sma/preview.hpp: `mode preview`, `cool W`, the default for
// references): ~860 B of RAM and ~13 KB of flash the Uno's one image does not have yet
// (docs/control.md section 17); on in the Mega image (sma_firmware_mega).
#ifndef RIG_FEATURE_PREVIEW
#define RIG_FEATURE_PREVIEW 0
#endif
#ifndef SMA_CONSOLE_PREVIEW
#define SMA_CONSOLE_PREVIEW RIG_FEATURE_PREVIEW
#endif
// Inverse + PID with the known future (sma::LeadConfig: `mode ffpid` on step, sine and traj,
// `lead F`): in every image, the Uno's float and Q16.16 ones included (docs/control.md section 36).
#ifndef RIG_FEATURE_LEAD
#define RIG_FEATURE_LEAD 1
#endif
#ifndef SMA_CONSOLE_LEAD
#define SMA_CONSOLE_LEAD RIG_FEATURE_LEAD
#endif

struct RigBoard {
  static constexpr double tick_hz() { return RIG_TICK_HZ; }
  static constexpr double v_max() { return RIG_V_MAX; }
  static constexpr double v_supply() { return RIG_V_SUPPLY; }
  static constexpr unsigned long pwm_top() { return RIG_PWM_TOP; }
  static constexpr double adc_vref() { return RIG_ADC_VREF; }
  static constexpr double adc_counts() { return RIG_ADC_COUNTS; }
  static constexpr double sensor_mm_per_v() { return RIG_SENSOR_MM_PER_V; }
  static constexpr double sensor_offset_mm() { return RIG_SENSOR_OFFSET_MM; }
  static constexpr double sensor_v_min() { return RIG_SENSOR_V_MIN; }
  static constexpr double sensor_v_max() { return RIG_SENSOR_V_MAX; }
  static constexpr double t_limit_C() { return RIG_T_LIMIT_C; }
  static constexpr double link_timeout_s() { return RIG_LINK_TIMEOUT_S; }
  static constexpr double stroke_mm() { return RIG_STROKE_MM; }
  static constexpr bool model() { return RIG_FEATURE_MODEL != 0; }
  static constexpr bool train() { return RIG_FEATURE_TRAIN != 0; }
  static constexpr bool compensate() { return RIG_FEATURE_COMPENSATE != 0; }
  static constexpr bool preview() { return RIG_FEATURE_PREVIEW != 0; }
  static constexpr bool lead() { return RIG_FEATURE_LEAD != 0; }
};

#endif  // RIG_BOARD_H
