// The rig constants of the Board's tests (native and the AVR compile test): an Uno-like rig
// (100 Hz tick, 5 V supply, Timer1 TOP 15999, 10-bit ADC, a 0.4 mm/V sensor) with every
// feature on. A test that needs another rig derives from it and hides what differs.
#ifndef SMA_TEST_BOARD_TEST_RIG_HPP
#define SMA_TEST_BOARD_TEST_RIG_HPP

struct BoardTestRig {
  static constexpr double tick_hz() { return 100; }
  static constexpr double v_max() { return 2.0; }
  static constexpr double v_supply() { return 5.0; }
  static constexpr unsigned long pwm_top() { return 15999; }
  static constexpr double adc_vref() { return 5.0; }
  static constexpr double adc_counts() { return 1024; }
  static constexpr double sensor_mm_per_v() { return 0.4; }
  static constexpr double sensor_offset_mm() { return -0.5; }
  static constexpr double sensor_v_min() { return 0.1; }
  static constexpr double sensor_v_max() { return 4.9; }
  static constexpr double t_limit_C() { return 110.0; }
  static constexpr double link_timeout_s() { return 0.0; }
  static constexpr double stroke_mm() { return 1.5; }
  static constexpr bool model() { return true; }
  static constexpr bool train() { return true; }
  static constexpr bool compensate() { return true; }
};

#endif  // SMA_TEST_BOARD_TEST_RIG_HPP
