// Model parameters in EEPROM (sma/storage.hpp) against a fake EEPROM: blank, corrupt CRC, wrong
// version, a power loss at every byte of an upload, round trips, keys and ranges.
#include <gtest/gtest.h>

#include <string.h>

#include <string>
#include <vector>

#include "sma/storage.hpp"

namespace st = sma::storage;

namespace {

// 1 KB of EEPROM (erased = 0xFF) that stops accepting writes after `budget` of them: what a
// power loss in the middle of an upload leaves behind.
struct Mem {
  uint8_t b[1024];
  long budget = -1;  // writes left; -1 = unlimited
  long writes = 0;
  Mem() { memset(b, 0xFF, sizeof b); }
};
struct FakeEeprom {
  Mem* m = nullptr;
  uint8_t read(uint16_t a) const { return a < 1024 ? m->b[a] : 0xFF; }
  void write(uint16_t a, uint8_t v) {
    if (m->budget == 0) return;
    if (m->budget > 0) --m->budget;
    ++m->writes;
    if (a < 1024) m->b[a] = v;
  }
};
typedef st::Store<FakeEeprom> Store;

Store make(Mem& m) {
  FakeEeprom e;
  e.m = &m;
  return Store(e);
}

struct Name {
  std::string s;
  void put(char c) { s.push_back(c); }
};
std::string key_name(uint8_t k) {
  Name n;
  st::put_key_name(n, k);
  return n.s;
}

// A wire that is not the paper's (valid).
void other_wire(sma::Params& p, sma::Effects& fx) {
  p.T_AS = 55.25;
  p.T_AF = 84.125;
  p.h = 214.5;
  p.g = 1.1496;
  p.n_loops = 2;
  p.loops[1].j = 0.25;
  fx.sensor_delay_s = 0.05;
  fx.ambient_offset_K = 1.5;
}

void upload(Store& s, const sma::Params& p, const sma::Effects& fx) {
  sma::Params cur;
  sma::Effects curfx;
  if (s.active() < 0) s.begin_from(cur, curfx);
  else s.begin_copy();
  for (uint8_t k = 0; k < st::kNumKeys; ++k) s.set_value(k, st::get_value(p, fx, k));
  uint8_t bad = 0;
  sma::Params scratch;
  sma::Effects fxs;
  ASSERT_EQ(s.commit(scratch, fxs, bad), nullptr);
}

void expect_same_as_float(const sma::Params& a, const sma::Effects& afx, const sma::Params& b,
                          const sma::Effects& bfx) {
  for (uint8_t k = 0; k < st::kNumKeys; ++k)
    EXPECT_EQ(static_cast<float>(st::get_value(a, afx, k)), static_cast<float>(st::get_value(b, bfx, k)))
        << key_name(k);
}

}  // namespace

TEST(StorageKeys, EveryKeyHasANameThatMapsBack) {
  for (uint8_t k = 0; k < st::kNumKeys; ++k) {
    const std::string n = key_name(k);
    ASSERT_FALSE(n.empty());
    EXPECT_EQ(st::key_index(n.c_str(), static_cast<uint8_t>(n.size())), k) << n;
  }
  EXPECT_EQ(key_name(0), "rho");
  EXPECT_EQ(key_name(17), "g");
  EXPECT_EQ(key_name(20), "m2");
  EXPECT_EQ(key_name(st::kFirstLoop + 4), "loop1.T_ii");
  EXPECT_EQ(key_name(st::kFirstEffect), "sensor_delay.delay_s");
  EXPECT_EQ(key_name(st::kKeyLoops), "loops");
  EXPECT_EQ(st::key_index("beta_per_K", 10), st::kFirstEffect + 5);  // the parameter alone
  EXPECT_EQ(st::key_index("delay_s", 7), st::kFirstEffect);
  for (const char* bad : {"", "rh", "rhoo", "m6", "m", "loop8.T_i", "loop0.T", "loop0.", "sensor_delay",
                          "sensor_delay.tau_s", "T_as", "sensor_calibration.", ".gain"})
    EXPECT_EQ(st::key_index(bad, static_cast<uint8_t>(strlen(bad))), st::kNoKey) << bad;
}

TEST(StorageKeys, DefaultsLieInsideTheirRanges) {
  const sma::Params p;
  const sma::Effects fx;
  for (uint8_t k = 0; k < st::kNumKeys; ++k) {
    double lo, hi;
    st::key_range(k, lo, hi);
    const double v = st::get_value(p, fx, k);
    EXPECT_TRUE(v >= lo && v <= hi) << key_name(k) << " " << v;
  }
}

TEST(StorageKeys, ThermalExpansionIsNotStored) {
  EXPECT_EQ(st::key_index("alpha_per_K", 11), st::kNoKey);  // the board does not store it
}

TEST(Storage, Crc16IsCcittFalse) {
  uint16_t c = 0xFFFF;
  for (const char* p = "123456789"; *p; ++p) c = st::crc16(c, static_cast<uint8_t>(*p));
  EXPECT_EQ(c, 0x29B1);
}

TEST(Storage, BlankEepromGivesDefaults) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  EXPECT_EQ(s.load(p, fx), -1);
  EXPECT_EQ(s.active(), -1);
  EXPECT_EQ(m.writes, 0);  // loading never writes
}

TEST(Storage, RoundTrip) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  other_wire(p, fx);
  upload(s, p, fx);
  EXPECT_EQ(s.active(), 0);
  Store s2 = make(m);  // a reboot
  sma::Params q;
  sma::Effects qfx;
  ASSERT_EQ(s2.load(q, qfx), 0);
  expect_same_as_float(p, fx, q, qfx);
  EXPECT_EQ(q.n_loops, 2);
  EXPECT_EQ(s2.crc(), s.crc());
  EXPECT_EQ(s2.seq(), 1);
  // A second upload goes to the other slot, with a newer sequence.
  p.T_AS = 53.0;
  upload(s2, p, fx);
  EXPECT_EQ(s2.active(), 1);
  Store s3 = make(m);
  ASSERT_EQ(s3.load(q, qfx), 1);
  EXPECT_EQ(static_cast<float>(q.T_AS), 53.0f);
  EXPECT_EQ(s3.seq(), 2);
  // And a third back to slot 0; the sequence wraps correctly past 255.
  for (int i = 0; i < 300; ++i) {
    p.T_AS = 50.0 + (i % 7);
    upload(s3, p, fx);
  }
  Store s4 = make(m);
  ASSERT_GE(s4.load(q, qfx), 0);
  EXPECT_EQ(static_cast<float>(q.T_AS), static_cast<float>(50 + (299 % 7)));
}

TEST(Storage, CorruptCrcFallsBackToTheOtherSlotThenDefaults) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  other_wire(p, fx);
  upload(s, p, fx);  // slot 0, seq 1
  p.T_AS = 53.0;
  upload(s, p, fx);  // slot 1, seq 2
  m.b[s.slot(1) + 40] ^= 0x01;  // one bit of slot 1's payload
  Store s2 = make(m);
  sma::Params q;
  sma::Effects qfx;
  ASSERT_EQ(s2.load(q, qfx), 0);
  EXPECT_EQ(static_cast<float>(q.T_AS), 55.25f);
  m.b[s.slot(0) + 3] ^= 0x80;  // slot 0's stored CRC
  Store s3 = make(m);
  EXPECT_EQ(s3.load(q, qfx), -1);
}

TEST(Storage, WrongVersionIsIgnored) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  upload(s, p, fx);
  m.b[s.slot(0) + 1] = st::kVersion + 1;
  Store s2 = make(m);
  EXPECT_EQ(s2.load(p, fx), -1);
}

TEST(Storage, ValidCrcButNonPhysicalSetIsIgnored) {
  // A set written by another firmware with a valid CRC but values check() refuses.
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  upload(s, p, fx);
  s.begin_copy();
  s.set_value(8, 40.0);  // T_AF < T_AS
  uint8_t bad = 0;
  sma::Params scratch;
  sma::Effects fxs;
  const char* msg = s.commit(scratch, fxs, bad);
  ASSERT_NE(msg, nullptr);
  EXPECT_EQ(bad, 8);
  EXPECT_EQ(s.active(), 0);
  EXPECT_EQ(s.staging(), 1);  // still open: fix it or abort
  s.set_value(8, 81.0);
  ASSERT_EQ(s.commit(scratch, fxs, bad), nullptr);
  EXPECT_EQ(s.active(), 1);
}

TEST(Storage, EffectFailureNamesTheEffectKey) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  s.begin_from(p, fx);
  s.set_value(st::kFirstEffect + 2, 0.1);  // sensor_calibration.gain
  uint8_t bad = 0;
  ASSERT_NE(s.commit(p, fx, bad), nullptr);
  EXPECT_EQ(bad, st::kFirstEffect + 2);
  EXPECT_EQ(s.active(), -1);
  s.abort();
  EXPECT_EQ(s.staging(), -1);
}

// A power loss after every possible number of writes of an upload: the old set (or the defaults
// on a blank EEPROM) stays active, unless the very last byte (the commit mark) was written.
TEST(Storage, InterruptedUploadAtEveryByteKeepsTheOldSet) {
  for (int prior = 0; prior < 3; ++prior) {  // 0: blank EEPROM, 1: one set, 2: two sets
    Mem base;
    sma::Params old_p;
    sma::Effects old_fx;
    old_p.T_AS = 51.0;
    {
      Store s = make(base);
      for (int i = 0; i < prior; ++i) {
        old_p.T_AS = 51.0 + i;
        upload(s, old_p, old_fx);
      }
    }
    sma::Params new_p;
    sma::Effects new_fx;
    other_wire(new_p, new_fx);
    // Count the writes of a full upload.
    long total = 0;
    {
      Mem m = base;
      m.writes = 0;
      Store s = make(m);
      sma::Params t;
      sma::Effects tfx;
      s.load(t, tfx);
      upload(s, new_p, new_fx);
      total = m.writes;
    }
    ASSERT_GT(total, st::kSlotSize);
    for (long cut = 0; cut <= total; ++cut) {
      Mem m = base;
      {
        Store s = make(m);
        sma::Params t;
        sma::Effects tfx;
        s.load(t, tfx);
        m.budget = cut;
        if (s.active() < 0) s.begin_from(sma::Params(), sma::Effects());
        else s.begin_copy();
        for (uint8_t k = 0; k < st::kNumKeys; ++k) s.set_value(k, st::get_value(new_p, new_fx, k));
        uint8_t bad = 0;
        s.commit(t, tfx, bad);
      }
      m.budget = -1;
      Store s = make(m);  // power back
      sma::Params q;
      sma::Effects qfx;
      const int8_t slot = s.load(q, qfx);
      if (cut == total) {
        ASSERT_GE(slot, 0);
        expect_same_as_float(new_p, new_fx, q, qfx);
      } else if (prior == 0) {
        ASSERT_EQ(slot, -1) << "cut " << cut;
      } else {
        ASSERT_GE(slot, 0) << "cut " << cut;
        ASSERT_EQ(static_cast<float>(q.T_AS), static_cast<float>(old_p.T_AS)) << "cut " << cut;
        ASSERT_EQ(s.seq(), prior) << "cut " << cut;
      }
    }
  }
}

TEST(Storage, StagingDoesNotTouchTheActiveSlot) {
  Mem m;
  Store s = make(m);
  sma::Params p;
  sma::Effects fx;
  upload(s, p, fx);
  std::vector<uint8_t> before(m.b + s.slot(0), m.b + s.slot(0) + st::kSlotSize);
  s.begin_copy();
  for (uint8_t k = 0; k < st::kNumKeys; ++k) s.set_value(k, 1.0);
  uint8_t bad = 0;
  EXPECT_NE(s.commit(p, fx, bad), nullptr);
  EXPECT_EQ(std::vector<uint8_t>(m.b + s.slot(0), m.b + s.slot(0) + st::kSlotSize), before);
  EXPECT_EQ(s.read_value(0, 0), sma::Params().rho);
}

TEST(StorageKeys, ValuePointersAreTheNamedFields) {
  sma::Params p;
  sma::Effects fx;
  EXPECT_EQ(st::value_ptr(p, fx, 0), &p.rho);
  EXPECT_EQ(st::value_ptr(p, fx, 6), &p.T_amb);
  EXPECT_EQ(st::value_ptr(p, fx, 14), &p.T_MSf);
  EXPECT_EQ(st::value_ptr(p, fx, 15), &p.q);
  EXPECT_EQ(st::value_ptr(p, fx, 16), &p.e);
  EXPECT_EQ(st::value_ptr(p, fx, 17), &p.g);
  EXPECT_EQ(st::value_ptr(p, fx, 18), &p.m[0]);
  EXPECT_EQ(st::value_ptr(p, fx, 23), &p.m[5]);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstLoop), &p.loops[0].T_i);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstLoop + 4), &p.loops[1].T_ii);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstEffect - 1), &p.loops[7].j);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstEffect), &fx.sensor_delay_s);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstEffect + 3), &fx.sensor_offset_mm);
  EXPECT_EQ(st::value_ptr(p, fx, st::kFirstEffect + 7), &fx.latent_heat_J);
  EXPECT_EQ(st::value_ptr(p, fx, st::kKeyLoops), nullptr);
  double lo, hi;
  st::key_range(3, lo, hi);  // d0
  EXPECT_FLOAT_EQ(static_cast<float>(hi), 0.01f);
  st::key_range(st::kFirstEffect + 6, lo, hi);  // k_R
  EXPECT_FLOAT_EQ(static_cast<float>(lo), -0.9f);
}
