// sma_params FILE.json: a params JSON (interfaces.md) through the project's one reader
// (sma_tools::read_model: unknown keys, non-physical sets -> a message naming the key, exit 1),
// printed as the firmware's flat keys (sma/storage.hpp), one `key value` per line, every key
// (missing ones at the paper's values). Used by `tools/sma upload` (pset/pget on the board).
#include <stdio.h>

#include <string>

#include "sma/storage.hpp"
#include "sma_tools/params_json.hpp"

namespace {
struct Name {
  std::string s;
  void put(char c) { s.push_back(c); }
};
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    fprintf(stderr, "usage: sma_params FILE.json   (prints 'key value' per line, the board's keys)\n");
    return 2;
  }
  sma_tools::Model m;
  try {
    m = sma_tools::read_model(argv[1]);
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
