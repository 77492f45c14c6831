// Voltage programs for the plant-B logs (docs/plant2.md), 100 Hz, V across the wire in 0..2 V.
// Chosen to differ from the own-plant benchmark's steps and shortened ramp: a sine drive, the
// paper's decaying ramp with six peaks (Fig. 4), seeded random staircases with rests, and a
// step sequence with up- and down-steps inside the transformation band.
#ifndef SMA_PLANT2_EXCITATIONS_HPP
#define SMA_PLANT2_EXCITATIONS_HPP

#include <math.h>
#include <stdint.h>
#include <random>
#include <string>
#include <vector>

namespace plant2 {

constexpr double kDt = 0.01;  // the firmware's 100 Hz

struct Program {
  std::vector<double> v;  // one value per sample, held until the next
  void hold(double V, double seconds) {
    const size_t n = static_cast<size_t>(lround(seconds / kDt));
    v.insert(v.end(), n, V);
  }
  void ramp(double V0, double V1, double seconds) {
    const size_t n = static_cast<size_t>(lround(seconds / kDt));
    for (size_t k = 0; k < n; ++k) v.push_back(V0 + (V1 - V0) * static_cast<double>(k) / static_cast<double>(n));
  }
};

// 1.25 +- 0.4 V at a 20 s period (the wire swings through most of the band and back), between
// rests that show the cold and the cooling tail.
inline Program sine_drive() {
  Program p;
  p.hold(0.0, 3.0);
  const double period = 20.0, cycles = 7.0;
  const size_t n = static_cast<size_t>(lround(cycles * period / kDt));
  for (size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * kDt;
    p.v.push_back(1.25 + 0.4 * sin(2.0 * M_PI * t / period));
  }
  p.hold(0.0, 20.0);
  return p;
}

// The paper's training drive (Fig. 4): up-and-down ramps whose peaks decay, so each cooling
// starts from a lower peak (a family of minor loops); six peaks, 0.06 V/s.
inline Program decaying_ramp() {
  Program p;
  p.hold(0.0, 2.0);
  const double peaks[6] = {1.62, 1.50, 1.42, 1.36, 1.31, 1.26};
  const double slope = 0.06, bottom = 0.5;
  p.ramp(0.0, bottom, 2.0);
  for (double pk : peaks) {
    p.ramp(bottom, pk, (pk - bottom) / slope);
    p.ramp(pk, bottom, (pk - bottom) / slope);
    p.hold(bottom, 3.0);
  }
  p.hold(0.0, 15.0);
  return p;
}

// Random levels in 0.7..1.8 V held 4-10 s, with rests at 0 V (8-14 s) after about a third of
// them; the seed makes each log reproducible.
inline Program random_staircase(uint64_t seed, double seconds = 180.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> level(0.7, 1.8), hold(4.0, 10.0), rest(8.0, 14.0), u(0.0, 1.0);
  Program p;
  p.hold(0.0, 3.0);
  while (static_cast<double>(p.v.size()) * kDt < seconds - 15.0) {
    p.hold(level(rng), hold(rng));
    if (u(rng) < 0.33) p.hold(0.0, rest(rng));
  }
  p.hold(0.0, 15.0);
  return p;
}

// Steps up and down, some inside the band (1.1-1.4 V), some through it.
inline Program step_sequence() {
  Program p;
  const double steps[][2] = {{0.0, 3},  {1.3, 15}, {0.0, 12}, {1.6, 14}, {1.1, 12}, {0.0, 12},
                             {1.9, 10}, {1.4, 12}, {0.8, 12}, {1.5, 12}, {0.0, 15}};
  for (const auto& s : steps) p.hold(s[0], s[1]);
  return p;
}

inline Program excitation(const std::string& name, uint64_t seed) {
  if (name == "sine") return sine_drive();
  if (name == "ramp6") return decaying_ramp();
  if (name == "stairs") return random_staircase(seed);
  return step_sequence();
}

}  // namespace plant2

#endif  // SMA_PLANT2_EXCITATIONS_HPP
