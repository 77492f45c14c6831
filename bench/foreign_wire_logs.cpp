// bench_foreign_wire_logs: training logs of a wire that is not the paper's, for the
// foreign-wire benchmark (bench/foreign_wire.py) and its test: the paper's decaying ramp with
// six peaks (tools/plant2/excitations.hpp) drives
//   own.csv        the library's plant (sma::Plant) with the foreign wire,
//   plant_b.csv    plant B (plant_b.hpp, written apart from the library; docs/plant2.md) with
//                  the same wire, the literal reading of a re-heat,
//   plant_b_rpm.csv plant B with the library's reading (return-point memory),
// all at 100 Hz with the rig's 2 um noise (model.md). The foreign wire is the paper's with the
// heating side shifted by --dT-heat K (T_AS, T_AF, T_s, T_f, the loops' T_i, T_ii), the
// cooling side by --dT-cool K (T_MS, T_MF, T_MSs, T_MSf, e: the martensite start q + e of
// eq 10 moves with it), and h, g replaced.
//
//   bench_foreign_wire_logs --out DIR [--dT-heat -3] [--dT-cool 1.5] [--h 140] [--g 1.05]
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <string>
#include "../tools/plant2/excitations.hpp"
#include "sma_host/plant.hpp"
#include "sma_host/plant_b_rig.hpp"

namespace {

struct Foreign {
  double dT_heat = -3.0, dT_cool = 1.5, h = 140.0, g = 1.05;
};

sma::Params own_wire(const Foreign& f) {
  sma::Params p;
  p.T_AS += f.dT_heat, p.T_AF += f.dT_heat, p.T_s += f.dT_heat, p.T_f += f.dT_heat;
  for (uint8_t k = 0; k < p.n_loops; ++k) p.loops[k].T_i += f.dT_heat, p.loops[k].T_ii += f.dT_heat;
  p.T_MS += f.dT_cool, p.T_MF += f.dT_cool, p.T_MSs += f.dT_cool, p.T_MSf += f.dT_cool, p.e += f.dT_cool;
  p.h = f.h;
  p.g = f.g;
  return p;
}

sma_host::plant_b::Wire b_wire(const Foreign& f, bool rpm) {
  sma_host::plant_b::Wire w;
  w.T_AS += f.dT_heat, w.T_AF += f.dT_heat, w.T_s += f.dT_heat, w.T_f += f.dT_heat;
  for (int k = 0; k < 3; ++k) w.knot_Ti[k] += f.dT_heat, w.knot_Tii[k] += f.dT_heat;
  w.T_MS += f.dT_cool, w.T_MF += f.dT_cool, w.T_MSs += f.dT_cool, w.T_MSf += f.dT_cool, w.e += f.dT_cool;
  w.h = f.h;
  w.g_mm = f.g;
  w.return_point_memory = rpm;
  return w;
}

FILE* open_log(const std::string& path, const char* what) {
  FILE* out = fopen(path.c_str(), "w");
  if (!out) {
    fprintf(stderr, "bench_foreign_wire_logs: %s: cannot write\n", path.c_str());
    exit(1);
  }
  fprintf(out, "# foreign wire, paper's decaying ramp (6 peaks), %s\nt_s,v_V,d_mm\n", what);
  return out;
}

void write_own(const std::string& path, const Foreign& f, const plant2::Program& prog) {
  sma::RigOptions rig;
  rig.noise_mm = 0.002;
  rig.seed = 11;
  sma::Plant plant(own_wire(f), sma::Effects(), rig);
  FILE* out = open_log(path, "the library's plant");
  for (size_t k = 0; k < prog.v.size(); ++k) {
    fprintf(out, "%.2f,%.4f,%.5f\n", static_cast<double>(k) * plant2::kDt, prog.v[k], plant.measure());
    plant.step(prog.v[k], plant2::kDt);
  }
  fclose(out);
}

void write_b(const std::string& path, const Foreign& f, const plant2::Program& prog, bool rpm) {
  sma::RigOptions rig;
  rig.noise_mm = 0.002;
  rig.seed = 12;
  sma_host::plant_b::RigB plant(b_wire(f, rpm), sma_host::plant_b::WireEffects(), rig, plant2::kDt);
  FILE* out = open_log(path, rpm ? "plant B, return-point memory" : "plant B, literal reading");
  for (size_t k = 0; k < prog.v.size(); ++k) {
    fprintf(out, "%.2f,%.4f,%.5f\n", static_cast<double>(k) * plant2::kDt, prog.v[k], plant.measure());
    plant.step(prog.v[k], plant2::kDt);
  }
  fclose(out);
}

}  // namespace

int main(int argc, char** argv) {
  Foreign f;
  std::string dir;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (i + 1 >= argc) {
      fprintf(stderr, "bench_foreign_wire_logs: %s needs a value\n", k.c_str());
      return 2;
    }
    const char* v = argv[++i];
    if (k == "--out") dir = v;
    else if (k == "--dT-heat") f.dT_heat = atof(v);
    else if (k == "--dT-cool") f.dT_cool = atof(v);
    else if (k == "--h") f.h = atof(v);
    else if (k == "--g") f.g = atof(v);
    else {
      fprintf(stderr, "bench_foreign_wire_logs: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (dir.empty()) {
    fprintf(stderr, "usage: bench_foreign_wire_logs --out DIR [--dT-heat K] [--dT-cool K] [--h H] [--g MM]\n");
    return 2;
  }
  const plant2::Program prog = plant2::decaying_ramp();
  write_own(dir + "/own.csv", f, prog);
  write_b(dir + "/plant_b.csv", f, prog, false);
  write_b(dir + "/plant_b_rpm.csv", f, prog, true);
  printf("wrote %s/own.csv, plant_b.csv, plant_b_rpm.csv (%zu rows each)\n", dir.c_str(), prog.v.size());
  return 0;
}
