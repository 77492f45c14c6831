// Params JSON: contract of interfaces.md (flat keys, m, loops, effects; missing -> paper values,
// unknown -> error naming the key; Params::check on the result) and the round trip.
#include <gtest/gtest.h>
#include "sma_tools/params_json.hpp"

using sma_tools::Error;
using sma_tools::Model;
using sma_tools::model_from_text;
using sma_tools::model_to_json;

namespace {
std::string error_of(const std::string& text) {
  try {
    model_from_text(text, "p.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ParamsJson, EmptyObjectIsThePaper) {
  const Model m = model_from_text("{}", "p.json");
  const sma::Params paper;
  EXPECT_DOUBLE_EQ(m.p.h, paper.h);
  EXPECT_DOUBLE_EQ(m.p.T_AS, 50.2);
  EXPECT_EQ(m.p.n_loops, 3);
  EXPECT_DOUBLE_EQ(m.fx.sensor_gain, 1.0);
}

TEST(ParamsJson, ReadsAllKindsOfKeys) {
  const Model m = model_from_text(
      "{\"h\": 200, \"T_AS\": 52.5, \"g\": 1.2e0, \"m\": [1, -4, 10, -8, 0, 2],\n"
      " \"loops\": [{\"T_i\": 65, \"T_ii\": 62, \"j\": 0.2}],\n"
      " \"effects\": {\"sensor_delay\": {\"delay_s\": 0.12}, \"sensor_calibration\": {\"offset_mm\": -0.3}}}",
      "p.json");
  EXPECT_DOUBLE_EQ(m.p.h, 200);
  EXPECT_DOUBLE_EQ(m.p.T_AS, 52.5);
  EXPECT_DOUBLE_EQ(m.p.g, 1.2);
  EXPECT_DOUBLE_EQ(m.p.m[2], 10);
  ASSERT_EQ(m.p.n_loops, 1);
  EXPECT_DOUBLE_EQ(m.p.loops[0].T_ii, 62);
  EXPECT_DOUBLE_EQ(m.fx.sensor_delay_s, 0.12);
  EXPECT_DOUBLE_EQ(m.fx.sensor_offset_mm, -0.3);
  EXPECT_DOUBLE_EQ(m.p.T_AF, 80.1);  // missing -> paper
}

TEST(ParamsJson, UnknownKeysAreNamedWithTheirLine) {
  std::string e = error_of("{\n  \"h\": 100,\n  \"T_ASS\": 50\n}");
  EXPECT_NE(e.find("p.json:3: unknown key 'T_ASS'"), std::string::npos) << e;
  e = error_of("{\"effects\": {\"sensor_delays\": {\"delay_s\": 1}}}");
  EXPECT_NE(e.find("unknown effect 'sensor_delays'"), std::string::npos) << e;
  e = error_of("{\"effects\": {\"sensor_delay\": {\"delay\": 1}}}");
  EXPECT_NE(e.find("effect 'sensor_delay': unknown parameter 'delay'"), std::string::npos) << e;
  e = error_of("{\"loops\": [{\"T_i\": 65, \"T_ii\": 62, \"k\": 0.2}]}");
  EXPECT_NE(e.find("unknown key 'k'"), std::string::npos) << e;
  e = error_of("{\"loops\": [{\"T_i\": 65, \"T_ii\": 62}]}");
  EXPECT_NE(e.find("missing key 'j'"), std::string::npos) << e;
}

TEST(ParamsJson, WrongTypesAndShapes) {
  EXPECT_NE(error_of("{\"h\": \"big\"}").find("key 'h' must be a number, not a string"), std::string::npos);
  EXPECT_NE(error_of("{\"m\": [1, 2]}").find("'m' must be a list of 6 numbers"), std::string::npos);
  EXPECT_NE(error_of("[1, 2]").find("expected a JSON object"), std::string::npos);
}

TEST(ParamsJson, NonPhysicalValuesFailParamsCheck) {
  // The message is Params::check()'s: it starts with the key.
  EXPECT_NE(error_of("{\"h\": -5}").find("p.json: h: must be in 0.01..1e5"), std::string::npos);
  EXPECT_NE(error_of("{\"T_AF\": 40}").find("p.json: T_AF: must be > T_AS"), std::string::npos);
  EXPECT_NE(error_of("{\"effects\": {\"sensor_lag\": {\"tau_s\": -1}}}").find("p.json: sensor_lag.tau_s: must be in 0..5"),
            std::string::npos);
}

TEST(ParamsJson, SyntaxErrorsHaveLineNumbers) {
  std::string e = error_of("{\n  \"h\": 100,\n  \"g\": 1,\n}");
  EXPECT_NE(e.find("p.json:4: invalid JSON"), std::string::npos) << e;
  e = error_of("{\"h\": 100, \"h\": 120}");
  EXPECT_NE(e.find("key 'h' appears twice"), std::string::npos) << e;
  e = error_of("{\"h\": 1e999}");
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  e = error_of("{\"h\": 100");
  EXPECT_NE(e.find("invalid JSON"), std::string::npos) << e;
}

TEST(ParamsJson, RoundTripIsExact) {
  Model m;
  m.p.h = 214.50000000000003;
  m.p.T_AS = 55.2;
  m.p.loops[1].j = 0.123456789;
  m.fx.sensor_offset_mm = -0.0123;
  m.fx.latent_heat_J = 0.5;
  const Model back = model_from_text(model_to_json(m), "round");
  EXPECT_EQ(back.p.h, m.p.h);
  EXPECT_EQ(back.p.T_AS, m.p.T_AS);
  EXPECT_EQ(back.p.loops[1].j, m.p.loops[1].j);
  EXPECT_EQ(back.p.n_loops, m.p.n_loops);
  EXPECT_EQ(back.fx.sensor_offset_mm, m.fx.sensor_offset_mm);
  EXPECT_EQ(back.fx.latent_heat_J, m.fx.latent_heat_J);
  EXPECT_EQ(model_to_json(Model()).find("effects"), std::string::npos);  // identity: no key
}

TEST(ParamsJson, ThermalExpansionKey) {
  Model m = model_from_text("{\"effects\": {\"thermal_expansion\": {\"alpha_per_K\": 1.1e-5}}}", "te");
  EXPECT_EQ(m.fx.thermal_expansion_per_K, 1.1e-5);
  const Model back = model_from_text(model_to_json(m), "round");
  EXPECT_EQ(back.fx.thermal_expansion_per_K, 1.1e-5);
  // Outside 0..1e-4 (a negative coefficient would shorten a heated wire): refused, named.
  const std::string e = error_of("{\"effects\": {\"thermal_expansion\": {\"alpha_per_K\": 2e-4}}}");
  EXPECT_NE(e.find("alpha_per_K"), std::string::npos) << e;
}

TEST(ParamsJson, EffectArgument) {
  sma::Effects fx;
  sma_tools::set_effect_arg(fx, "sensor_delay.delay_s=0.1");
  EXPECT_DOUBLE_EQ(fx.sensor_delay_s, 0.1);
  EXPECT_THROW(sma_tools::set_effect_arg(fx, "sensor_delay=0.1"), Error);
  EXPECT_THROW(sma_tools::set_effect_arg(fx, "nope.x=1"), Error);
  EXPECT_THROW(sma_tools::set_effect_arg(fx, "latent_heat.L_J=abc"), Error);
}

TEST(ParamsJson, UnicodeEscapesNeedFourHexDigits) {
  // Found by fuzz_params_json: strtoul stopped early, so "\u0x68" became the key "h".
  EXPECT_NE(error_of("{\"\\u0x68\": 40}"), "");
  EXPECT_NE(error_of("{\"h\\uZZZZ\": 40}"), "");
  EXPECT_EQ(error_of("{\"\\u0068\": 40}"), "");  // a real escape of 'h' is fine
}

// The re-heat reading of the loop memory (hysteresis.hpp): optional, default return_point, written
// only when it is the other, anything else refused naming the key.
TEST(ParamsJson, ReheatKey) {
  EXPECT_TRUE(model_from_text("{}", "p").p.reheat == sma::Reheat::return_point);
  EXPECT_EQ(model_to_json(Model()).find("reheat"), std::string::npos);
  const Model m = model_from_text("{\"reheat\": \"new_loop\"}", "p");
  EXPECT_TRUE(m.p.reheat == sma::Reheat::new_loop);
  EXPECT_TRUE(model_from_text(model_to_json(m), "round").p.reheat == sma::Reheat::new_loop);
  EXPECT_TRUE(model_from_text("{\"reheat\": \"return_point\"}", "p").p.reheat == sma::Reheat::return_point);
  for (const char* bad : {"{\"reheat\": \"literal\"}", "{\"reheat\": 1}"}) {
    try {
      model_from_text(bad, "p.json");
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("'reheat'"), std::string::npos) << e.what();
    }
  }
}

// The host's names and messages of the parameter table come from one string writer
// (sma_host::StringSink): the board's spelling of a key, and check()'s message as the board
// prints it after "ERR " (docs/identification.md, "One parameter table").
TEST(ParamsJson, KeyNamesAndViolationMessagesAreTheTables) {
  using sma::param::Row;
  using sma::param::Rule;
  using sma::param::key_of;
  EXPECT_EQ(sma_host::key_name(key_of<Row::m>(3)), "m3");
  EXPECT_EQ(sma_host::key_name(key_of<Row::loop_T_ii>(1)), "loop1.T_ii");
  EXPECT_EQ(sma_host::key_name(key_of<Row::delay_s>()), "sensor_delay.delay_s");
  EXPECT_EQ(sma_host::key_unit(key_of<Row::h>()), "W/(m^2*K)");
  EXPECT_EQ(sma_host::key_unit(key_of<Row::loop_T_ii>(2)), "degC");
  EXPECT_EQ(sma_host::key_unit(key_of<Row::m>(4)), "1");
  EXPECT_EQ(sma_tools::violation_text({key_of<Row::T_AF>(), Rule::above}), "T_AF: must be > T_AS");
  EXPECT_EQ(sma_tools::violation_text({key_of<Row::gain>(), Rule::range}), "sensor_calibration.gain: must be in 0.2..5");
  sma::Params p;
  p.T_AF = p.T_AS - 1.0;  // eq 2: austenite finishes above its start
  EXPECT_EQ(sma_tools::violation_text(p.check()), "T_AF: must be > T_AS");
}

// The re-heat reading has one spelling in params JSON, reports and the tools' --reheat.
TEST(ParamsJson, ReheatReadingOneSpellingEverywhere) {
  for (sma::Reheat r : {sma::Reheat::return_point, sma::Reheat::new_loop}) {
    EXPECT_EQ(sma_tools::reheat_option(sma_host::reheat_name(r)), r);
    Model m;
    m.p.reheat = r;
    EXPECT_EQ(model_from_text(model_to_json(m), "p.json").p.reheat, r);
  }
  try {
    sma_tools::reheat_option("rpm");
    ADD_FAILURE() << "accepted --reheat rpm";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--reheat must be return_point or new_loop, not 'rpm'"), std::string::npos);
  }
}
