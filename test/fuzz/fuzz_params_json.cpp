// libFuzzer target: the params JSON reader (tools/host/include/sma_tools/params_json.hpp + json.hpp)
// on arbitrary bytes. It must return a checked Model or throw sma_tools::Error (never another
// exception, a crash, unbounded recursion or a leak). On success: the model passes
// Params::check() / Effects::check(), and writing it back (model_to_json) and reading that
// again gives exactly the same numbers (the writer's shortest round-trip format).
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <ctype.h>
#include <string.h>

#include <string>

#include "sma_tools/params_json.hpp"

namespace {
[[noreturn]] void fail(const char* what, const std::string& detail = "") {
  fprintf(stderr, "fuzz_params_json: invariant violated: %s %s\n", what, detail.c_str());
  abort();
}

bool same(const sma_tools::Model& a, const sma_tools::Model& b) {
  for (const auto& k : sma_tools::param_keys())
    if (!(sma_tools::value(a, k.key) == sma_tools::value(b, k.key))) return false;
  for (int i = 0; i < 6; ++i)
    if (!(a.p.m[i] == b.p.m[i])) return false;
  if (a.p.n_loops != b.p.n_loops) return false;
  for (int i = 0; i < a.p.n_loops; ++i)
    if (!(a.p.loops[i].T_i == b.p.loops[i].T_i && a.p.loops[i].T_ii == b.p.loops[i].T_ii &&
          a.p.loops[i].j == b.p.loops[i].j))
      return false;
  for (const auto& k : sma_tools::effect_keys())
    if (!(sma_tools::value(a, k.key) == sma_tools::value(b, k.key))) return false;
  return true;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  bool json_ok = true;
  try {
    (void)sma_tools::json::parse(text, "fuzz.json");
  } catch (const sma_tools::Error& e) {
    json_ok = false;
  }
#ifdef SMA_FUZZ_STRICT
  // RFC 8259: \u takes exactly 4 hex digits. In valid JSON every backslash is inside a string,
  // so a scan of the accepted text is exact. Off by default: the reader accepts \uZZZZ today
  // (test/fuzz/repro/json_bad_u_escape.json).
  if (json_ok) {
    for (size_t i = 0; i + 1 < text.size(); ++i) {
      if (text[i] != '\\') continue;
      if (text[i + 1] == 'u') {
        bool hex = i + 6 <= text.size();
        for (size_t k = 2; hex && k < 6; ++k) hex = isxdigit(static_cast<unsigned char>(text[i + k])) != 0;
        if (!hex) fail("an invalid \\u escape was accepted");
      }
      ++i;  // skip the escaped character
    }
  }
#endif
  sma_tools::Model m;
  try {
    m = sma_tools::model_from_text(text, "fuzz.json");
    if (!json_ok) fail("json::parse refused what model_from_text accepted");
  } catch (const sma_tools::Error& e) {
    if (strncmp(e.what(), "fuzz.json", 9) != 0) fail("error message does not name the file", e.what());
    return 0;
  }
  if (m.p.check()) fail("accepted parameters fail Params::check()", sma_tools::violation_text(m.p.check()).c_str());
  if (m.fx.check()) fail("accepted effects fail Effects::check()", sma_tools::violation_text(m.fx.check()).c_str());
  for (bool pretty : {true, false}) {
    const std::string out = sma_tools::model_to_json(m, pretty);
    sma_tools::Model back;
    try {
      back = sma_tools::model_from_text(out, "roundtrip.json");
    } catch (const sma_tools::Error& e) {
      fail("model_to_json output is refused by the reader:", std::string(e.what()) + "\n" + out);
    }
    if (!same(m, back)) fail("model_to_json -> model_from_text changes the model:", out);
  }
  return 0;
}
