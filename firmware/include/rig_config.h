// The rig: pins, sensor calibration, PWM, limits. The one file to edit for another rig.
// Plain macros so that both the firmware (avr-g++) and the virtual rig (host g++, tools/vrig)
// read the same numbers: the virtual rig inverts this calibration to drive the ADC pin.
//
// Wiring (Arduino Uno, ATmega328P at 16 MHz):
//   pin 9 (OC1A, PB1) -> K2232 MOSFET gate (add a 10 k pull-down: the pin floats during reset)
//   A0 (ADC0)         <- KEYENCE LC-2000 analog output, scaled into 0..5 V
//   USB serial        115200 8N1, line-based console (sma/console.hpp)
#ifndef RIG_CONFIG_H
#define RIG_CONFIG_H

#define RIG_F_CPU 16000000UL  // Uno crystal

// ---- heater PWM: Timer1 fast PWM, mode 14 (TOP = ICR1), non-inverting on OC1A -----------------
// 1 kHz with TOP = 15999: 16000 levels (~14 bits), far above the wire's thermal bandwidth
// (tau ~ 4 s), so the wire sees the mean power duty * Vs^2 / R and duty = (V / Vs)^2.
#define RIG_PWM_PIN 9
#define RIG_PWM_HZ 1000UL
#define RIG_PWM_TOP (RIG_F_CPU / RIG_PWM_HZ - 1UL)  // 15999: counts 0..TOP, duty n/(TOP+1)
#define RIG_V_SUPPLY 5.0                              // supply switched by the MOSFET, V
#define RIG_V_MAX 2.0                                 // eq 18: 0 <= V <= 2 V

// ---- control tick ------------------------------------------------------------------------------
// Timer2 CTC at exactly 1 kHz (prescaler 64, OCR2A = 249); every 10th compare is a tick.
#define RIG_TICK_HZ 100
#define RIG_TIMER2_OCR 249
#define RIG_TIMER2_DIV 10

// ---- displacement sensor: KEYENCE LC-2000 analog output on A0 ---------------------------------
// mm = RIG_SENSOR_MM_PER_V * volts + RIG_SENSOR_OFFSET_MM. The head's analog output range is
// set so that 0..5 V spans -0.5..1.5 mm (2 mm over 1024 counts: ~2 um per ADC count, the
// model's rig-like condition); the wire's stroke 0..0.958 mm is 1.25..3.645 V.
#define RIG_SENSOR_CHANNEL 0
#define RIG_ADC_VREF 5.0  // AVcc reference
#define RIG_ADC_COUNTS 1024
#define RIG_SENSOR_MM_PER_V 0.4
#define RIG_SENSOR_OFFSET_MM (-0.5)
// Valid analog range: outside it the sensor is lost (the LC-2000 saturates its output when the
// target is out of range or lost) and the safety latch turns the heater off.
#define RIG_SENSOR_V_MIN 0.1
#define RIG_SENSOR_V_MAX 4.9

// ---- limits ------------------------------------------------------------------------------------
#define RIG_T_LIMIT_C 110.0    // wire temperature estimate limit at boot (console tlim changes it)
// Largest setpoint the console accepts (pos, traj), mm: the sensor's range above the rest
// position. The uploaded model's stroke g lowers it (a setpoint past g cannot be reached).
#define RIG_STROKE_MM 1.5
#define RIG_LINK_TIMEOUT_S 0.0  // 0 = losing the serial link is not a fault
#define RIG_BAUD 115200UL
// Reset cause: Optiboot (the Uno's bootloader) clears MCUSR and passes its value in r2. Set to 0
// for a board flashed without a bootloader that passes r2 (r2 is then undefined at reset and
// could fake a watchdog reset).
#define RIG_RESET_CAUSE_FROM_R2 1

#endif  // RIG_CONFIG_H
