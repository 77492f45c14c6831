// Test fixture: writes a rig log simulated by the plant with effects hidden in it.
//   make_log OUT.csv [effect.param=value ...]     (steps excitation, 2 um noise, seed 4)
#include <cstdio>
#include <string>
#include "sma_host/discrepancy.hpp"
#include "sma_tools/params_json.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: make_log OUT.csv [effect.param=value ...]\n");
    return 2;
  }
  sma::Effects fx;
  try {
    for (int i = 2; i < argc; ++i) sma_tools::set_effect_arg(fx, argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_log: %s\n", e.what());
    return 1;
  }
  const sma_host::RigLog log = sma_host::simulate_log(sma::Params(), fx, sma_host::default_steps(), 0.002, 4);
  FILE* f = std::fopen(argv[1], "w");
  if (!f) return 1;
  std::fprintf(f, "# rig: simulated by make_log\nt_s,v_V,d_mm\n");
  for (size_t k = 0; k < log.size(); ++k) std::fprintf(f, "%.2f,%.4f,%.6f\n", log.t[k], log.v[k], log.d[k]);
  std::fclose(f);
  return 0;
}
