// The displacement sensor of plant B (plant_b.hpp): what happens to the wire's displacement on
// its way into a rig log. Written independently of the library's sensor model (docs/plant2.md):
//   delay:       a ring buffer of the 100 Hz samples, read between two samples by linear
//                interpolation (a fractional delay, not rounded to ticks);
//   lag:         first-order low-pass discretized by the bilinear (Tustin) transform;
//   calibration: gain and offset of the laser's analog output;
//   noise:       white Gaussian, then optional ADC quantization (counts of adc_mm).
#ifndef SMA_HOST_PLANT_B_SENSOR_HPP
#define SMA_HOST_PLANT_B_SENSOR_HPP

#include <math.h>
#include <stdint.h>
#include <random>
#include <vector>

namespace sma_host {
namespace plant_b {

struct SensorEffects {
  double delay_s = 0.0;
  double lag_s = 0.0;
  double gain = 1.0, offset_mm = 0.0;
  double noise_mm = 0.0;  // RMS
  double adc_mm = 0.0;    // quantization step, 0 = none
};

class Sensor {
 public:
  Sensor(const SensorEffects& fx, double dt, uint64_t seed) : fx_(fx), dt_(dt), rng_(seed) {
    // enough history for the delay plus the interpolation partner
    ring_.assign(static_cast<size_t>(ceil(fx.delay_s / dt)) + 2, 0.0);
    const double two_tau = 2.0 * fx.lag_s;
    a_ = (two_tau - dt) / (two_tau + dt);  // y_k = a y_{k-1} + b (x_k + x_{k-1})
    b_ = dt / (two_tau + dt);
  }

  // The log's value for the true displacement x at this sample (called once per sample).
  double read(double x) {
    const double delayed = delay(x);
    double y = delayed;
    if (fx_.lag_s > 0.0) {
      y = first_ ? delayed : a_ * y_prev_ + b_ * (delayed + x_prev_);
      y_prev_ = y;
      x_prev_ = delayed;
    }
    first_ = false;
    double m = fx_.gain * y + fx_.offset_mm;
    if (fx_.noise_mm > 0.0) m += fx_.noise_mm * normal_(rng_);
    if (fx_.adc_mm > 0.0) m = fx_.adc_mm * floor(m / fx_.adc_mm + 0.5);
    return m;
  }

 private:
  double delay(double x) {
    if (fx_.delay_s <= 0.0) return x;
    const size_t n = ring_.size();
    if (count_ == 0)
      for (double& r : ring_) r = x;  // the wire was at rest before the log
    head_ = (head_ + 1) % n;
    ring_[head_] = x;
    ++count_;
    const double back = fx_.delay_s / dt_;  // samples into the past
    const size_t k = static_cast<size_t>(floor(back));
    const double frac = back - static_cast<double>(k);
    const double newer = ring_[(head_ + n - k) % n], older = ring_[(head_ + n - k - 1) % n];
    return newer + frac * (older - newer);
  }

  SensorEffects fx_;
  double dt_;
  std::vector<double> ring_;
  size_t head_ = 0, count_ = 0;
  double a_ = 0.0, b_ = 0.0, y_prev_ = 0.0, x_prev_ = 0.0;
  bool first_ = true;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace plant_b
}  // namespace sma_host

#endif  // SMA_HOST_PLANT_B_SENSOR_HPP
