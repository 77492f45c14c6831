// The sensor path, compensated (issue 7): what the controller should take for the position
// when the displacement measurement has a fitted calibration error, lag or delay (effects.hpp).
//
//  - calibration: measured = gain D + offset, inverted exactly;
//  - lag and delay: a Smith predictor. A model of the wire (the controller's eq-1 temperature
//    estimate, walked through the same Hysteresis and eq 12) predicts the position now, y_m, and
//    what the sensor shows of it, y_s (y_m through the sensor's dynamics); the feedback is
//    measured + (y_m - y_s): the measurement moved forward by what the model says the sensor has
//    not shown yet. Where the model is right this removes the sensor's phase lag from the loop;
//    where it is wrong the measurement still anchors the feedback.
//  - the delay is modelled as part of a first-order lag (time constant lag + delay): a delay
//    line of 0.3 s at 100 Hz would cost more RAM than the Uno has left, and against the wire's
//    4 s thermal time constant the first-order model keeps the bulk of the correction.
// Optional: the controller does not need it; the firmware includes it only if RAM allows.
#ifndef SMA_SENSOR_HPP
#define SMA_SENSOR_HPP

#include "derived.hpp"
#include "effects.hpp"
#include "hysteresis.hpp"
#include "mechanics.hpp"
#include "params.hpp"
#include "scalar.hpp"

namespace sma {

template <class T>
class SensorPredictor {
 public:
  SensorPredictor(const PhaseCurves<T>& curves, const Params& p, const Effects& fx, double dt)
      : SensorPredictor(curves, p, fx, dt, from_double<T>(fx.ambient_C(p.T_amb))) {}
  // With the true ambient T_amb + ambient offset as the scalar (the controller's thermal model has it).
  SensorPredictor(const PhaseCurves<T>& curves, const Params& p, const Effects& fx, double dt, T T_amb_true)
      : inv_gain_(reciprocal_as<T>(fx.sensor_gain)),
        offset_(from_field<T>(fx.sensor_offset_mm)),
        a_(low_pass_gain_as<T>(dt, fx.sensor_lag_s + fx.sensor_delay_s + 1e-9)),
        path_(fx.sensor_lag_s + fx.sensor_delay_s > 0.0             ? Path::Predicted
              : fx.sensor_gain != 1.0 || fx.sensor_offset_mm != 0.0 ? Path::Calibrated
                                                                    : Path::Raw),
        y_s_(T(0)),
        walker_(curves, T_amb_true, T(0)),
        mech_(p, fx) {}

  // Restart from a wire at rest at T0 with fraction eps0 (a mode change).
  void reset(T T0, T eps0) {
    walker_.reset(T0, eps0);
    y_s_ = mech_.displacement(walker_.eps(), T0);
  }

  // One tick: the raw measurement and the controller's wire temperature estimate for this
  // instant (before this tick's voltage) -> the position the controller should act on.
  T correct(T measured, T wire_temperature) {
    if (path_ == Path::Raw) return measured;  // no effect uploaded: nothing to undo (a multiply less a tick)
    const T d = (measured - offset_) * inv_gain_;  // calibration, inverted
    if (path_ == Path::Calibrated) return d;
    const T y_m = mech_.displacement(walker_.update(wire_temperature), wire_temperature);
    y_s_ = y_s_ + a_ * (y_m - y_s_);
    return d + (y_m - y_s_);
  }

  bool dynamic() const { return path_ == Path::Predicted; }

 private:
  // (The scalars first: on the AVR a load reaches 63 bytes past the predictor's address.)
  T inv_gain_, offset_, a_;
  // What correct() has to do: nothing, the calibration, or the calibration and the predictor.
  enum class Path : uint8_t { Raw, Calibrated, Predicted } path_;
  T y_s_;
  Hysteresis<T> walker_;
  Mechanics<T> mech_;
};

}  // namespace sma

#endif  // SMA_SENSOR_HPP
