// sma_model: position control of a shape-memory-alloy wire actuator, after
// "Position Control for an SMA Actuator Based on Inverse Model for Compensation".
// The one header a user includes. Header-only, C++14, builds on AVR (no STL, no heap, no
// exceptions) and on the host. Every model template takes its scalar type: float, double or
// sma::Fixed (Q16.16).
#ifndef SMA_MODEL_H
#define SMA_MODEL_H

#include "sma/scalar.hpp"
#include "sma/fixed.hpp"
#include "sma/params.hpp"
#include "sma/effects.hpp"
#include "sma/thermal.hpp"
#include "sma/hysteresis.hpp"
#include "sma/mechanics.hpp"
#include "sma/inverse.hpp"
#include "sma/pid.hpp"
#include "sma/controller.hpp"
#include "sma/sensor.hpp"
#include "sma/reference.hpp"
#include "sma/training.hpp"
#include "sma/storage.hpp"

#endif  // SMA_MODEL_H
