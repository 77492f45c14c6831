// Prints the host's fingerprint of sma::Fixed results (see sweep.hpp) as 0x%08x, for comparison
// with the one the AVR benchmark computes in simavr (avr_math_cycles --expect-hash).
#include <stdio.h>

#include "sweep.hpp"

int main() {
  printf("0x%08lx\n", static_cast<unsigned long>(sweep::fixed_results_hash()));
  return 0;
}
