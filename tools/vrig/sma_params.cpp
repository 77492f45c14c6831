// sma_params FILE.json: a params JSON (interfaces.md) through the project's one reader
// (sma_tools::read_model: unknown keys, non-physical sets -> a message naming the key, exit 1),
// printed as the firmware's flat keys (sma/storage.hpp), one `key value` per line, every key
// (missing ones at the paper's values). Used by `tools/sma upload` (pset/pget on the board).
// sma_params --from-keys: the reverse, `key value` lines on stdin (what `tools/sma download`
// read with pget) -> the params JSON on stdout through the project's one writer; an unknown key,
// a bad number or a non-physical set -> a message naming the line or key, exit 1.
#include <stdio.h>
#include <stdlib.h>

#include <iostream>
#include <sstream>
#include <string>

#include "sma/storage.hpp"
#include "sma_tools/params_json.hpp"

namespace {
struct Name {
  std::string s;
  void put(char c) { s.push_back(c); }
};
}  // namespace

int from_keys() {
  sma_tools::Model m;
  std::string line;
  int n = 0;
  while (std::getline(std::cin, line)) {
    ++n;
    if (line.empty()) continue;
    std::istringstream is(line);
    std::string key, val;
    is >> key >> val;
    char* end = nullptr;
    const double v = strtod(val.c_str(), &end);
    const uint8_t k = key.size() < 255 ? sma::storage::key_index(key.c_str(), static_cast<uint8_t>(key.size()))
                                       : sma::storage::kNoKey;
    if (k == sma::storage::kNoKey || val.empty() || *end != 0) {
      fprintf(stderr, "sma_params: stdin line %d: expected '<key> <number>' with a board key: '%s'\n", n, line.c_str());
      return 1;
    }
    if (k == sma::storage::kKeyLoops) {
      if (!(v >= 0 && v <= sma::kMaxLoopKnots)) {
        fprintf(stderr, "sma_params: stdin line %d: loops %g out of 0..%d\n", n, v, sma::kMaxLoopKnots);
        return 1;
      }
      m.p.n_loops = static_cast<uint8_t>(v);
    } else {
      *sma::storage::value_ptr(m.p, m.fx, k) = v;
    }
  }
  try {
    sma_tools::check_model(m, "stdin");
  } catch (const std::exception& e) {
    fprintf(stderr, "sma_params: %s\n", e.what());
    return 1;
  }
  printf("%s\n", sma_tools::model_to_json(m).c_str());
  return 0;
}

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--from-keys") return from_keys();
  if (argc != 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    fprintf(stderr, "usage: sma_params FILE.json   (prints 'key value' per line, the board's keys)\n"
                    "       sma_params --from-keys   ('key value' lines on stdin -> params JSON)\n");
    return 2;
  }
  sma_tools::Model m;
  try {
    m = sma_tools::read_model(argv[1]);
    // The firmware's loop memory is the return-point reading only (params.hpp: compiled out on
    // AVR): a model identified with the other reading would run differently on the board.
    if (m.p.reheat != sma::Reheat::return_point)
      throw sma_tools::Error(std::string(argv[1]) + ": key 'reheat' is \"" +
                             sma_tools::reheat_name(m.p.reheat) +
                             "\", but the board runs \"return_point\" only");
  } catch (const std::exception& e) {
    fprintf(stderr, "sma_params: %s\n", e.what());
    return 1;
  }
  for (uint8_t k = 0; k < sma::storage::kNumKeys; ++k) {
    Name n;
    sma::storage::put_key_name(n, k);
    printf("%s %.9g\n", n.s.c_str(), sma::storage::get_value(m.p, m.fx, k));
  }
  return 0;
}
