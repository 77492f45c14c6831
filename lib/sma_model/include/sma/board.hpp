// The board's logic as one hardware-free unit: console state, controller (eq 18), sensor
// compensation (sensor.hpp), safety latch, reference and training run, model store and
// telemetry. The firmware (firmware/src/main.cpp) keeps only ISRs and hardware glue; the virtual
// rig's --native mode, the console fuzzer, the soak's reference and the host tests drive this same
// unit, so they cannot drift from the firmware.
//
//   bytes in  -> rx() -> handle_line() [-> run_model_op() at the top of the caller's stack]
//   ADC sum / count / out-of-range count of one tick -> control() -> PWM counts 0..TOP+1
//   report(): the telemetry row and a fault announcement of that tick
//   poll(): what a loop pass owes outside the tick (the end of a training run)
//
// Template parameters:
//   T   the scalar of the control path (float, or sma::Fixed for Q16.16);
//   Rig the rig's constants as static constexpr functions (firmware/include/rig_board.h maps
//       rig_config.h onto them): tick_hz, v_max, v_supply, pwm_top, adc_vref, adc_counts,
//       sensor_mm_per_v, sensor_offset_mm, sensor_v_min, sensor_v_max, t_limit_C,
//       link_timeout_s, stroke_mm, and the features model(), train(), compensate();
//   Hw  the board's outputs: bool line(const char*, uint8_t) (false: dropped), the EEPROM
//       (uint8_t read(uint16_t) const, void write(uint16_t, uint8_t): it is storage::Store's E),
//       uint8_t irq_off() / void irq_restore(uint8_t) around the deepest stack.
//
// Settings change only when a command sets them: the latch's limit starts at Rig::t_limit_C()
// and only `tlim` changes it; the controller's open-loop voltage only `volt`/`train`; its gains
// only `gains`/`mode`. The console's limits are the rig's (V_max) and the model's (stroke g,
// capped by the rig's sensor range).
//
// AVR notes: RAM is 2 KB and the stack shares it. The controller and the reference generator are
// built in place (unions below): sma::Params (193 B) lives only while the models compute their
// constants, in the generator's storage. The heavy member functions are noinline so that their
// frames are never on the stack together with the control tick.
#ifndef SMA_BOARD_HPP
#define SMA_BOARD_HPP

#include <stddef.h>
#include <stdint.h>
#if defined(__AVR__)
#include <avr/pgmspace.h>
#endif
#if defined(__AVR__)
// avr-libc has no <new>: the placement form the unions below need, inline (the Arduino core's
// <new.h> declares it out of line: a call per construction; the firmware does not use the core).
inline void* operator new(size_t, void* place) noexcept { return place; }
#else
#include <new>
#endif
#include "console.hpp"
#include "controller.hpp"
#include "preview.hpp"
#include "reference.hpp"
#include "safety.hpp"
#include "scalar.hpp"
#include "sensor.hpp"
#include "storage.hpp"
#include "training.hpp"
#include "trunc_u32.hpp"

#define SMA_NOINLINE __attribute__((noinline))

namespace sma {

// The preview's plan passes after each tick (Board::plan()) are its config's
// PreviewConfig::plan_passes(): the next tick's lead sample, then steps_per_tick grid steps
// (PreviewController::plan_step). On the 16 MHz Mega the passes (the lead <= ~50 k cycles, a grid
// step ~8-27 k) and the tick (<= 16 k; the telemetry row after the passes) fit in the 10 ms tick
// (160 k cycles); a tick that comes first is counted (Board::plan_short()).

namespace detail {
// The plan's passes after each tick (Board::plan()); on a board without the preview an empty
// base that plans nothing (no RAM).
template <bool On>
struct PlanPace {
  bool pace_done() const { return true; }
  void pace_pass(bool) {}
  void pace_arm(uint8_t) {}
  void pace_tick(bool, uint8_t) {}
  uint16_t pace_short() const { return 0; }
};
template <>
struct PlanPace<true> {
  PlanPace() : left_(0), short_(0) {}
  bool pace_done() const { return left_ == 0; }
  // One pass; `complete`: it completed a plan (the tick's planning is done).
  void pace_pass(bool complete) { left_ = complete ? uint8_t(0) : static_cast<uint8_t>(left_ - 1); }
  void pace_arm(uint8_t passes) { left_ = passes; }
  // A tick: one that came before the last one's passes were done is counted (`planning`: the
  // preview runs).
  void pace_tick(bool planning, uint8_t passes) {
    if (left_ && planning && short_ < 0xFFFFu) ++short_;
    pace_arm(passes);
  }
  uint16_t pace_short() const { return short_; }

 private:
  uint8_t left_;    // passes left after this tick (0: its planning is done)
  uint16_t short_;  // ticks counted by pace_tick()
};

// A telemetry row written after the plan's passes (Board::rows_after_plan()): its tick's figures,
// kept from report() to telemetry() (the next control() overwrites Live's).
struct LateRow {
  uint32_t ticks;
  double v, d_mm, ref_mm;
  uint16_t counts;
  bool waits;
};

// Where report() keeps a row for telemetry() (Board::rows_after_plan()): nothing on a board
// without the preview.
template <bool On>
struct RowSlot {
  bool rows_later() const { return false; }
  void set_rows_later(bool) {}
  LateRow* late_row() { return nullptr; }
};
template <>
struct RowSlot<true> {
  bool rows_later() const { return later_; }
  void set_rows_later(bool later) { later_ = later; }
  LateRow* late_row() { return &row_; }

 private:
  bool later_;
  LateRow row_;
};

// Rig::preview(), or false for a rig that does not name the feature.
template <class R>
constexpr auto rig_preview(int) -> decltype(R::preview()) { return R::preview(); }
template <class R>
constexpr bool rig_preview(long) { return false; }
// Rig::lead(), or false for a rig that does not name the feature.
template <class R>
constexpr auto rig_lead(int) -> decltype(R::lead()) { return R::lead(); }
template <class R>
constexpr bool rig_lead(long) { return false; }
// The next tick's reference and, on a board with the lead, its known future
// (Board::prepare_future).
template <class T, bool kLead>
struct FutureSlot {
  T* now() { return &future_.now; }
  Lookahead<T>* future() { return &future_; }
  void set_lead(bool lead) { lead_ = lead; }
  bool lead() const { return lead_; }
  Lookahead<T> future_;
  bool lead_;  // Board::lead_on() when it was prepared
};
template <class T>
struct FutureSlot<T, false> {
  T* now() { return &now_; }
  Lookahead<T>* future() { return nullptr; }
  void set_lead(bool) {}
  bool lead() const { return false; }
  T now_;
};
// Rig::preview_steps_per_tick(), or the default config's.
template <class R>
constexpr auto rig_steps_per_tick(int) -> decltype(R::preview_steps_per_tick()) { return R::preview_steps_per_tick(); }
template <class R>
constexpr uint8_t rig_steps_per_tick(long) { return PreviewConfig().steps_per_tick; }
}  // namespace detail

template <class T, class Rig, class Hw>
class Board : private detail::PlanPace<detail::rig_preview<Rig>(0)> {
  typedef detail::LateRow LateRow;

 public:
  // The preview controller (sma/preview.hpp, Rig::preview()): `mode preview`, `cool W`, the
  // default for references; it plans between ticks (plan()).
  static constexpr bool kPreview = detail::rig_preview<Rig>(0);
  static_assert(!kPreview || SMA_CONSOLE_PREVIEW, "the preview needs its console rows (SMA_CONSOLE_PREVIEW 1)");
  // Inverse + PID with the known future (Rig::lead(), LeadConfig): `mode ffpid` on a reference
  // uses it, `lead F` sets its trade-off. In both Uno images, float and Q16.16.
  static constexpr bool kLead = detail::rig_lead<Rig>(0);
  static_assert(!kLead || SMA_CONSOLE_LEAD, "the lead needs its console row (SMA_CONSOLE_LEAD 1)");
  typedef Controller<T> Ctl;
  typedef ReferenceGen<T> Gen;
  typedef console::LineBuffer::Status LineStatus;

  explicit Board(Hw hw = Hw()) : store_(hw) {
    // The console's state and the Zeroed members are declared one after the other (increasing
    // addresses): one memset from the first to the end of the last (AVR: one loop instead of
    // five); initial_state() then writes the state's non-zero defaults.
    memset(static_cast<void*>(&v_), 0,
           static_cast<size_t>(reinterpret_cast<char*>(&live_ + 1) - reinterpret_cast<char*>(&v_)));
    initial_safety(&safety_.x);
    initial_state(&state_.s);
#if SMA_CONSOLE_PREVIEW
    if (kPreview) state_.s.mode = state_.s.loop_mode = Mode::Preview;
#endif
  }
  Board(const Board&) = delete;
  Board& operator=(const Board&) = delete;

  // At reset, heater off: the models from the EEPROM (or the paper's), the ready line, and a
  // latched watchdog fault if the last run hung.
  void boot(bool watchdog_reset, const char* banner_f) {
    build_models();
    start_reference();
    live_.x.temp_C = to_double(ctl().wire_temperature());
    safety_.x.boot(watchdog_reset);
    reply_.x.clear();
    reply_.x.put_f(banner_f);
    send();
    if (watchdog_reset) announce_fault();
  }

  // ---- bytes in --------------------------------------------------------------------------------
  // One received byte. True when a line (or a bad line) is complete: the caller stops reading and
  // calls handle_line() when it has the time (the slowest reply takes ~2 ms on the Uno).
  bool rx(char c) {
    safety_.x.on_rx();
    const LineStatus st = line_.x.push(c);
    if (st == LineStatus::Pending) return false;
    v_.x.waiting_ = st;
    return true;
  }
  bool line_waiting() const { return v_.x.waiting_ != LineStatus::Pending; }

  SMA_NOINLINE void handle_line() {
    telemetry();  // a row that waits for the plan's passes goes before the reply, as without them
    const LineStatus st = v_.x.waiting_;
    v_.x.waiting_ = LineStatus::Pending;
    if (st == LineStatus::Line) {
      console::Command c;
      const bool rows_before = state_.s.tele && !state_.s.plot;
      if (console::execute(line_.x.line(), state_.s, safety_.x.fault(), reply_.x, limits(), &c)) {
        if (c.op == console::Op::Status) console::status_line(reply_.x, state_.s, live_.x);
        if (Rig::model() && console::is_model_op(c.op)) {  // run_model_op() replies
          v_.x.model_op_ = c.op;
          v_.x.model_key_ = c.key;
          v_.x.model_a_ = static_cast<float>(c.a);
          return;
        }
        apply(c, rows_before);
      }
    } else if (st != LineStatus::Pending) {
      console::line_error(st, reply_.x);
    }
    send();
  }

  // ---- model commands: run at the top of the caller's stack -------------------------------------
  bool model_pending() const { return Rig::model() && v_.x.model_op_ != console::Op::Empty; }
  // Runs the pending model command. True when it wrote the EEPROM (pbegin, pset, pcommit: up to
  // seconds on the AVR, heater off): the caller's tick count must catch up (set_ticks()).
  SMA_NOINLINE bool run_model_op() {
    console::Command c;
    c.op = v_.x.model_op_;
    c.key = v_.x.model_key_;
    c.a = v_.x.model_a_;
    v_.x.model_op_ = console::Op::Empty;
    const bool write = c.op == console::Op::PBegin || c.op == console::Op::PCommit;
    if (write) model_write(c);
    else model_read(c);
    send();
    return write || c.op == console::Op::PSet;
  }

  // ---- the tick ----------------------------------------------------------------------------------
  // The tick's ADC samples (sum, count, count outside the sensor's valid range) -> PWM counts n,
  // duty n / (pwm_top + 1) = (V / V_supply)^2, 0 = heater off.
  // The whole section runs in T, from the integers in to the integers out (Scalar operations
  // ratio, floor_u16; the sine's phase from the tick count): a Q16.16 board converts nothing to
  // float here. The figures for status and telemetry are converted in report(), after the PWM.
  SMA_NOINLINE uint16_t control(uint32_t adc_sum, uint8_t adc_n, uint8_t adc_bad) {
    // The sensor's mean voltage (no sample: -1 V, sensor lost) and the position it reads.
    static_assert(Rig::adc_counts() == 1024.0, "adc_volts: a 10-bit ADC");
    const T volts =
        adc_n ? adc_volts<T>(adc_sum, adc_n, T(Rig::adc_vref() / Rig::adc_counts()), T(Rig::adc_vref())) : T(-1);
    const T mm = T(Rig::sensor_mm_per_v()) * volts + T(Rig::sensor_offset_mm());
    // The position the controller acts on: calibration undone, lag and delay compensated.
    const T d = Rig::compensate() ? sensor().correct(mm, wire_temperature()) : mm;
    v_.x.last_d_ = d;

    const uint32_t k = v_.x.ticks_ - v_.x.run_start_;
    T ref = T(0);
    if (Rig::train() && v_.x.training_) {  // the training signal, open loop (the latch still applies)
      if (k >= gen_.train.end_ticks) {
        if (state_.s.training) v_.x.train_done_ = true;
        state_.s.training = false;
        state_.s.heat = false;
        ctl().set_mode(Mode::Off, d);
      } else {
        ctl().set_voltage(from_double<T>(training_voltage(t_of(k))));
      }
    } else {
      // (The reference prepared between ticks, prepare_future: the control section does not
      // evaluate it. A tick the slot was not prepared for, once after an overrun or an EEPROM
      // write, reads the one prepared before.)
      ref = kPreview ? ref_at(t_of(k)) : *v_.x.now();
    }
    // (The preview runs instead of the Controller: its wire estimate is the one watched.)
    const T v_cmd = preview_on() ? preview().step(ref, Future{this, t_of(k)}, d) : (kLead ? ctl().step(ref, d, *v_.x.future(), v_.x.lead()) : ctl().step(ref, d));

    SafetyInputOf<T> in;
    in.sensor_v = volts;
    in.samples_in_range = adc_bad == 0 && adc_n > 0;
    in.measured_mm = mm;
    in.wire_temp_C = wire_temperature();
    in.command_v = v_cmd;
    in.heating = state_.s.heat;
    const T v = safety_.x.gate(in);
    if (safety_.x.tripped() && state_.s.heat) {
      v_.x.fault_due_ = true;
      state_.s.heat = false;
      state_.s.training = false;
      ctl().set_mode(Mode::Off, d);
    }
    v_.x.counts_ = pwm_counts(v);
    stash(live_.x.d_mm, mm);
    stash(live_.x.ref_mm, ref);
    stash(live_.x.v, v);
    return v_.x.counts_;
  }

  // After control() (and the PWM written): the tick's figures for status and telemetry, the
  // telemetry row and a fault announcement of that tick. With rows_after_plan(true) (a board with
  // the preview) the row (~16 k AVR cycles) and the announcement wait for telemetry(), so that
  // the plan's passes start that much earlier in the tick (docs/control.md section 22).
  SMA_NOINLINE void report() {
    live_.x.ticks = v_.x.ticks_;
    live_.x.t_ref_s = t_of(v_.x.ticks_ - v_.x.run_start_);
    double* slot = &live_.x.d_mm;  // d_mm, ref_mm, v: consecutive (console::Live)
    for (uint8_t i = 0; i < 3; ++i) slot[i] = unstash(slot[i]);
    live_.x.temp_C = to_double(wire_temperature());
    live_.x.fault = safety_.x.fault();
    ctl().prepare_next_tick(kLead && v_.x.lead());  // a reversal's loop ahead of its tick (Controller)
    prepare_future(v_.x.ticks_ - v_.x.run_start_ + 1u);  // the next tick's reference, likewise
    if (preview_on()) preview().prepare_next_tick();  // the preview's model wire, likewise
    if (state_.s.tele) {
      if (v_.x.header_due_ && !state_.s.plot) {
        reply_.x.clear();
        reply_.x.put_f(console::telemetry_header());
        send();
        v_.x.header_due_ = false;
      }
      if (kPreview && v_.x.rows_later()) {
        LateRow* r = v_.x.late_row();
        if (r->waits) telemetry();  // the last tick's: no time was left for it after its passes
        r->ticks = v_.x.ticks_;
        r->v = live_.x.v;
        r->d_mm = live_.x.d_mm;
        r->ref_mm = live_.x.ref_mm;
        r->counts = v_.x.counts_;
        r->waits = true;
      } else {
        console::telemetry_row(reply_.x, v_.x.ticks_, static_cast<uint16_t>(Rig::tick_hz()), live_.x.v, live_.x.d_mm,
                               live_.x.ref_mm, static_cast<float>(v_.x.counts_) / static_cast<float>(Rig::pwm_top() + 1UL),
                               state_.s.plot);
        send();
      }
    }
    ++v_.x.ticks_;
    constexpr uint8_t kPasses = plan_passes();
    this->pace_tick(preview_on(), kPasses);  // the next tick's plan passes (plan())
    if (v_.x.fault_due_ && !row_waits()) announce_fault();
  }
  // Telemetry rows after the plan passes (telemetry()), or in report() (the default).
  void rows_after_plan(bool later) { v_.x.set_rows_later(later); }
  bool row_waits() { return kPreview && v_.x.rows_later() && v_.x.late_row()->waits; }
  // The row report() left (and a fault announcement of its tick, after it), or nothing: the
  // caller writes it when the tick's planning is done and it has the time (~16 k AVR cycles);
  // otherwise the next report() writes it before its own.
  void telemetry() {
    if (!row_waits()) return;
    LateRow* r = v_.x.late_row();
    r->waits = false;
    // (report()'s row, written out again: a shared helper reorders the Uno image's functions, +20 B.)
    console::telemetry_row(reply_.x, r->ticks, static_cast<uint16_t>(Rig::tick_hz()), r->v, r->d_mm, r->ref_mm,
                           static_cast<float>(r->counts) / static_cast<float>(Rig::pwm_top() + 1UL), state_.s.plot);
    send();
    if (v_.x.fault_due_) announce_fault();
  }

  // Between ticks, when the caller has ~2 ms before the next one: one bounded step of the
  // preview's plan (PreviewController::plan_step, <= ~27 k AVR cycles in float), at most
  // plan_passes() after a tick, fewer when a plan completes. True when the tick's planning is done
  // (then a call does nothing): the caller may call it as often as its time allows. Never from an
  // interrupt that can preempt control().
  SMA_NOINLINE bool plan() {
    if (this->pace_done()) return true;
    this->pace_pass(!preview_on() || preview().plan_step(Future{this, static_cast<float>(live_.x.t_ref_s)}));
    return this->pace_done();
  }
  // The plan passes after each tick: those of the preview's config (preview_config(): the rig's
  // steps_per_tick, PreviewConfig::plan_passes), 0 without the preview.
  static constexpr uint8_t plan_passes() { return kPreview ? preview_config().plan_passes() : uint8_t(0); }
  // Ticks that came before the last one's planning was done (the caller ran out of time: the board
  // then ran less plan than the host proves).
  uint16_t plan_short() const { return this->pace_short(); }

  // Outside the tick: a training run that ended (its storage back to a generator, the line).
  void poll() {
    if (!Rig::train()) return;
    if (v_.x.training_ && !state_.s.training) {
      v_.x.training_ = false;
      start_reference();
    }
    if (v_.x.train_done_) {
      v_.x.train_done_ = false;
      reply_.x.clear();
      reply_.x.put_f(SMA_F("# train done: heater off"));
      send();
    }
  }

  // ---- ticks -------------------------------------------------------------------------------------
  uint32_t ticks() const { return v_.x.ticks_; }
  // The caller's timer raised tick `raised` while the previous one ran too long: counted (status
  // ovr=) and skipped to.
  void overrun_to(uint32_t raised) {
    if (live_.x.overruns < 0xFFFFu) ++live_.x.overruns;
    v_.x.ticks_ = raised;
  }
  // After a long EEPROM operation (heater off meanwhile): the ticks it blocked are not overruns.
  void set_ticks(uint32_t t) { v_.x.ticks_ = t; }

  // ---- read access (tests, the host) -------------------------------------------------------------
  const console::State& state() const { return state_.s; }
  const SafetyLatch<T>& safety() const { return safety_.x; }
  const console::Live& live() const { return live_.x; }
  const Ctl& controller() const { return ctl(); }
  console::Limits limits() const {
    console::Limits lim;
    lim.g_mm = v_.x.g_mm_;
    lim.v_max = Rig::v_max();
    lim.model = Rig::model();
    lim.train = Rig::train();
    lim.preview = kPreview;
    lim.single = true;
    return lim;
  }
  bool training() const { return v_.x.training_; }
  storage::Store<Hw>& store() { return store_; }

  static constexpr SafetyConfig safety_config() {
    SafetyConfig c{};
    c.t_limit_C = Rig::t_limit_C();
    c.sensor_v_min = Rig::sensor_v_min();
    c.sensor_v_max = Rig::sensor_v_max();
    c.link_timeout_s = Rig::link_timeout_s();
    c.dt = 1.0 / Rig::tick_hz();
    return c;
  }
  // The controller's config: the rig's tick and V_max, the ffpid mode's default gains. A
  // constant, checked at compile time (the controller then skips its run-time check).
  static constexpr ControllerConfig controller_config() {
    ControllerConfig c{};
    c.dt = 1.0 / Rig::tick_hz();
    c.v_max = Rig::v_max();
    c.gains = console::kGainsFfpid;
    return c;
  }
  static_assert(controller_config().check() == nullptr, "the rig's controller config is valid (ControllerConfig::check)");
  // In place: on AVR a copy of the constant in flash (a local ControllerConfig keeps its
  // 48-byte initial image in .data: RAM for good).
  static SMA_NOINLINE void controller_config(ControllerConfig* c) {
#if defined(__AVR__)
    static constexpr ControllerConfig kConfig PROGMEM = controller_config();
    memcpy_P(c, &kConfig, sizeof(ControllerConfig));
#else
    new (c) ControllerConfig(controller_config());
#endif
  }

  // Effective volts -> PWM counts n of duty (V / V_supply)^2, n / (TOP + 1); below one count: 0.
  static uint16_t pwm_counts(T v) {
    const T top1 = T(Rig::pwm_top() + 1.0);
    // n = (v sqrt(TOP + 1) / V_supply)^2: the factor folds at compile time (no division in the
    // tick) and stays small (~25 for 16000 counts at 5 V, where (TOP + 1) / V_supply^2 = 640 would
    // take Q16.16's long multiply).
    constexpr double kNPerV = sqrt_constexpr(Rig::pwm_top() + 1.0) / Rig::v_supply();
    const T n_per_v = T(kNPerV);
    const T nv = v * n_per_v;
    T nf = nv * nv + T(0.5);
    if (!(nf >= T(1))) return 0;  // also NaN
    if (nf > top1) nf = top1;
    return floor_u16(nf);
  }

 private:
  // Storage without construction at static-init time.
  struct Models {
    Ctl ctl;
    SensorPredictor<T> sensor;
    PreviewSlot<T, kPreview> preview;
  };
  union ModelStore {
    ModelStore() {}
    ~ModelStore() {}
    Models m;
  };
  struct Training {      // the training signal being played (train)
    TrainingPlan plan;
    TrainingPlan::Cursor at;  // the cycle of the last tick (each tick walks on from it)
    uint32_t end_ticks;  // its length in ticks
  };
  // A member whose initial value is all zero bytes (Live, LineBuffer, Reply: every default is 0),
  // set by the constructor's memset instead of a store per field (AVR: ~4 B of flash per byte of
  // the board).
  template <class X>
  union Zeroed {
    Zeroed() {}
    ~Zeroed() {}
    X x;
  };
  union SafetyStore {  // constructed by initial_safety()
    SafetyStore() {}
    ~SafetyStore() {}
    SafetyLatch<T> x;
  };
  union StateStore {  // constructed by initial_state()
    StateStore() {}
    ~StateStore() {}
    console::State s;
  };
  union GenStore {  // the generator, or the Params while the models are built, or a training plan
    GenStore() {}
    ~GenStore() {}
    Gen gen;
    Params params;
    Training train;
  };

  Ctl& ctl() { return models_.m.ctl; }
  const Ctl& ctl() const { return models_.m.ctl; }
  SensorPredictor<T>& sensor() { return models_.m.sensor; }
  Gen& gen() { return gen_.gen; }
  PreviewSlot<T, kPreview>& preview() { return models_.m.preview; }
  bool preview_on() const { return kPreview && ctl().mode() == Mode::Preview; }
  // The wire temperature estimate of the controller running (the latch and the compensation).
  T wire_temperature() const { return preview_on() ? models_.m.preview.wire_temperature() : ctl().wire_temperature(); }
  // The reference tau seconds after t (the preview's view of the known future).
  struct Future {
    Board* b;
    float t;
    T operator()(T tau) const { return b->ref_at(t + static_cast<float>(to_double(tau))); }
  };
  // control() leaves its figures for Live in Live's own slots as T (a Q16.16 -> float conversion
  // costs ~100 cycles of the control section; no RAM of their own); report() converts them.
  static void stash(double& slot, T x) {
    static_assert(sizeof(T) <= sizeof(double), "a T fits a Live slot");
    memcpy(&slot, &x, sizeof(T));
  }
  static double unstash(const double& slot) {
    T x;
    memcpy(&x, &slot, sizeof(T));
    return to_double(x);
  }
  // Seconds since the run's start at its tick k (the training plan, the preview, status).
  static SMA_NOINLINE float t_of(uint32_t k) { return static_cast<float>(k) * static_cast<float>(1.0 / Rig::tick_hz()); }
  // The reference at t (one copy of ReferenceGen::at for the tick and the preview's future).
  SMA_NOINLINE T ref_at(float t) { return gen().at(t); }
  // The preview's config: the rig's tick, V_max, PWM and (if it names one) steps_per_tick.
  static constexpr PreviewConfig preview_config() {
    PreviewConfig c;
    c.steps_per_tick = detail::rig_steps_per_tick<Rig>(0);
    c.dt = 1.0 / Rig::tick_hz();
    c.v_max = Rig::v_max();
    c.v_supply = Rig::v_supply();
    c.pwm_top = static_cast<uint16_t>(Rig::pwm_top());
    c.plan_in_step = false;
    return c;
  }

  void send() {
    if (reply_.x.len && !store_.eeprom().line(reply_.x.text, reply_.x.len) && live_.x.dropped < 0xFFFFu)
      ++live_.x.dropped;
  }

  // The one place the models are constructed (the controller's constructor is large: inlined
  // twice it would cost kilobytes of flash). Interrupts off meanwhile: this is the deepest stack
  // of the firmware, no ISR frame on top of it.
  SMA_NOINLINE void construct(const Params& p, const Effects& fx) {
    const uint8_t s = store_.eeprom().irq_off();
    // The controller's config lives in the sensor predictor's storage while the controller is
    // built (the predictor is built next over it): 48 B less on the deepest stack.
    static_assert(sizeof(SensorPredictor<T>) >= sizeof(ControllerConfig), "config scratch");
    ControllerConfig* cfg = reinterpret_cast<ControllerConfig*>(static_cast<void*>(&models_.m.sensor));
    controller_config(cfg);
    new (&models_.m.ctl) Ctl(p, fx, *cfg, CheckedConfig());
    if (Rig::compensate())
      new (&models_.m.sensor)
          SensorPredictor<T>(ctl().inverse().curves(), p, fx, 1.0 / Rig::tick_hz(), ctl().inverse().thermal().T_a);
    if (kPreview) {
      preview().build(ctl().inverse().curves(), ctl().inverse().thermal(), p, fx, preview_config(), ctl().valid());
      preview().set_cool_weight(state_.s.cool_weight);
    }
    v_.x.g_mm_ = static_cast<float>(p.g < Rig::stroke_mm() ? p.g : Rig::stroke_mm());
    store_.eeprom().irq_restore(s);
  }

  // A set is valid when the controller built from it is (Controller::valid(): Params::check(),
  // Effects::check()). Reading check()'s messages would keep ~600 B of them in AVR RAM.
  struct Validator {
    Board* b;
    const char* operator()(const Params& p, const Effects& fx, uint8_t& bad_key) const {
      bad_key = storage::kNoKey;
      b->construct(p, fx);
      return b->ctl().valid() ? nullptr : SMA_F("invalid model");
    }
  };

  // The paper's values into `p`: on AVR a copy of a constant in flash (the constructor's stores
  // cost ~500 B of flash).
#if defined(__AVR__)
  static const Params& paper() {
    static const Params kPaper PROGMEM = Params();
    return kPaper;
  }
  template <class X>
  static X read_paper(const X* field) {  // a field of paper()
    X x;
    memcpy_P(&x, field, sizeof(X));
    return x;
  }
  static SMA_NOINLINE void paper_params(Params* p) { memcpy_P(p, &paper(), sizeof(Params)); }
#else
  static const Params& paper() {
    static const Params kPaper = Params();
    return kPaper;
  }
  template <class X>
  static X read_paper(const X* field) { return *field; }
  static SMA_NOINLINE void paper_params(Params* p) { new (p) Params(); }
#endif

  // The latch with the rig's config: on AVR a copy of a constant in flash (its stores cost
  // ~100 B of the static constructor).
#if defined(__AVR__)
  static void initial_safety(SafetyLatch<T>* s) {
    static constexpr SafetyLatch<T> kSafety PROGMEM = SafetyLatch<T>(safety_config());
    memcpy_P(s, &kSafety, sizeof(SafetyLatch<T>));
  }
#else
  static void initial_safety(SafetyLatch<T>* s) { new (s) SafetyLatch<T>(safety_config()); }
#endif

  // The console's initial state: the console's defaults with the latch's limit of the rig. On
  // AVR, over the constructor's zeroes, copies of the constants in flash with non-zero defaults
  // (constructed in place, its ~250 bytes of defaults cost a store each: ~1 KB of the static
  // constructor; copied whole, the trajectory's zero points took 129 B of flash).
  static constexpr console::Settings initial_settings() {
    console::Settings c{};
    c.tlim_C = Rig::t_limit_C();
    return c;
  }
#if defined(__AVR__)
  static void initial_state(console::State* s) {
    static constexpr console::Settings kSettings PROGMEM = initial_settings();
    static constexpr RefShape kShape PROGMEM = console::trajectory_shape();
    memcpy_P(static_cast<console::Settings*>(s), &kSettings, sizeof(console::Settings));
    memcpy_P(static_cast<RefShape*>(&s->traj), &kShape, sizeof(RefShape));
  }
#else
  static void initial_state(console::State* s) {
    new (s) console::State();
    static_cast<console::Settings&>(*s) = initial_settings();
  }
#endif

  // The models from the active set in EEPROM, or the paper's values when there is none. The
  // Params live in the generator's storage meanwhile (start_reference() afterwards).
  SMA_NOINLINE void build_models() {
    Params* p = &gen_.params;
    Effects fx;
    Validator v = {this};
    if (!Rig::model() || store_.load(*p, fx, v) < 0) {
      paper_params(p);
      new (&fx) Effects();
      construct(*p, fx);
    }
    p->~Params();
  }

  // (Re)starts the generator on the console's reference (State::reference()). The trajectory's
  // Reference holds the paper's step and sine too (the console edits only its points): it is
  // lent to the generator as the run's kind, which saves a 190-byte temporary and its
  // construction code (flash).
  SMA_NOINLINE void start_reference() {
    v_.x.training_ = false;
    Reference& r = state_.s.traj;
    r.kind = state_.s.run_kind;
    r.constant_mm = state_.s.pos_mm;
    new (&gen_.gen) Gen(r, 1.0 / Rig::tick_hz());
    r.kind = RefKind::Trajectory;
    prepare_future(0u);
  }

  // Inverse + PID with the known future (LeadConfig) on the references that have one, each with
  // `lead F` times its tuned lead (lead_for).
  // (`lead 0`: the paper's inverse + PID.)
  bool lead_on() const {
    return kLead && ctl().mode() == Mode::FeedforwardPid && !v_.x.training_ && state_.s.run_kind != RefKind::Constant &&
           state_.s.lead > 0.0;
  }
  // The reference of run tick k and, where the lead is on, its known future
  // (ReferenceGen::lookahead), between ticks.
  SMA_NOINLINE void prepare_future(uint32_t k) {
    if (v_.x.training_) return;  // (gen_ holds the training plan)
    const bool lead = lead_on();
    v_.x.set_lead(lead);
    if (kPreview && !lead) return;  // (a board with the preview reads its reference itself: ref_at)
    const double dt = 1.0 / Rig::tick_hz();
    if (!kLead) {
      *v_.x.now() = gen().at_tick(k, dt);
      return;
    }
    const RefKind kind = state_.s.run_kind;
    // The lead: `lead F` times the tuned one of the reference's kind (lead_for), truncated to
    // ticks (exact for the tuned one; the ticks as an integer, 2-byte constants).
    const uint16_t tuned = static_cast<uint16_t>(kind == RefKind::MultiStep ? lead_for(RefKind::MultiStep).lead_ticks(dt)
                                                                            : lead_for(RefKind::Sine).lead_ticks(dt));
    *v_.x.future() = gen().lookahead(k, trunc_u32(state_.s.lead * tuned), LeadConfig().sample_ticks(dt), dt, lead);
  }

  // The model commands (storage.hpp via console::model_command) on `p`, a scratch Params.
  // pcommit builds the models from the staged set (Validator); refused, they are rebuilt from
  // the active set.
  // `defaults`: p is scratch the command may overwrite (pbegin, pcommit), filled with the
  // paper's values first (pbegin reads them when no set is active).
  SMA_NOINLINE void model_op(const console::Command& c, Params* p, bool defaults = true) {
    if (defaults) paper_params(p);
    Effects fx;
    Validator v = {this};
    if (!console::model_command(c, store_, *p, fx, reply_.x, v) && c.op == console::Op::PCommit)
      build_models();
  }
  // pbegin / pcommit need the heater off (the console refuses them otherwise): their scratch is
  // the generator's storage, the reference restarts afterwards.
  SMA_NOINLINE void model_write(const console::Command& c) {
    model_op(c, &gen_.params);
    ctl().set_gains(state_.s.gains());
    start_reference();
  }
  // pset / pget / pinfo / pabort may run while heating (the generator's storage is in use) and
  // need no Params: only pget without an active set reads a default, the paper's value of its
  // key straight from paper_value() (a Params on the stack here was the deepest frame).
  SMA_NOINLINE void model_read(const console::Command& c) {
    if (c.op == console::Op::PGet && store_.active() < 0) {
      reply_.x.clear();
      console::pget_default_line(reply_.x, c.key, paper_value(c.key));
      return;
    }
    // Read commands never touch the scratch set: the generator's storage stands in for it.
    model_op(c, &gen_.params, false);
  }
  // Key k of the paper's values (sma::Params(), sma::Effects()) without building a Params.
  static SMA_NOINLINE double paper_value(uint8_t k) {
    const Params& p = paper();
    Effects fx;
    if (k == storage::kKeyLoops) return read_paper(&p.n_loops);
    double* v = storage::value_ptr(const_cast<Params&>(p), fx, k);
    if (!v) return 0.0;
    return k < storage::kFirstEffect ? read_paper(v) : *v;
  }

  SMA_NOINLINE void announce_fault() {
    v_.x.fault_due_ = false;
    reply_.x.clear();
    reply_.x.put_f(SMA_F("# fault "));
    reply_.x.put_f(fault_name(safety_.x.fault()));
    reply_.x.put_f(SMA_F(": heater off"));
    send();
  }

  SMA_NOINLINE void start_training(double slope) {
    TrainingPlan* plan = &gen_.train.plan;
#if defined(__AVR__)
    // The paper's plan copied from flash: constructed, its arrays' initial values would sit in
    // .data (80 B of RAM for good).
    static constexpr TrainingPlan kPlan PROGMEM = TrainingPlan();
    memcpy_P(plan, &kPlan, sizeof(TrainingPlan));
#else
    new (plan) TrainingPlan();
#endif
    if (slope > 0.0) plan->slope = slope;
    new (&gen_.train.at) TrainingPlan::Cursor();
    // plan->duration() with its slope-free parts folded (the built-in plan's peaks and holds).
    constexpr double kHolds_s = TrainingPlan().holds_s(), kRamps2_V = 2.0 * TrainingPlan().ramp_V();
    const double length_s = kHolds_s + kRamps2_V / plan->slope;
    gen_.train.end_ticks = trunc_u32(length_s * Rig::tick_hz()) + 1u;
    v_.x.training_ = true;
    v_.x.run_start_ = v_.x.ticks_;
    reply_.x.put(' ');
    reply_.x.put_fixed(length_s, 1);
    reply_.x.put_f(SMA_F(" s"));
  }
  SMA_NOINLINE float training_voltage(float t) { return static_cast<float>(gen_.train.plan.voltage_at(t, gen_.train.at)); }

  // The controller, the latch and the reference follow an OK'd command: each setting only when
  // this command sets it.
  // `rows_before`: rig-log rows were streaming before this command (their header was sent).
  SMA_NOINLINE void apply(const console::Command& c, bool rows_before) {
    using console::Op;
    constexpr uint8_t kPasses = plan_passes();
    if (c.op == Op::Stop) safety_.x.clear();
    if (c.op == Op::Tlim) safety_.x.set_limit(state_.s.tlim_C);
    if (c.op == Op::Volt || c.op == Op::Train) ctl().set_voltage(from_double<T>(state_.s.volt));
    const Mode m = state_.s.active_mode();
    // A preview (re)started drops its lead sample: the tick's plan passes again, so that the next
    // tick does not sample it inside the control section.
    if (kPreview && m == Mode::Preview && m != ctl().mode()) {
      preview().start(ctl().wire_temperature(), v_.x.last_d_);
      this->pace_arm(kPasses);
    }
    // Leaving the preview: the controller did not step while it ran; its estimate continues
    // from the preview's (the latch and the inverse model start from it).
    if (kPreview && ctl().mode() == Mode::Preview && m != Mode::Preview)
      ctl().set_wire_temperature(preview().wire_temperature());
    if (m != ctl().mode()) ctl().set_mode(m, v_.x.last_d_);
    if (kPreview && c.op == Op::Cool) preview().set_cool_weight(state_.s.cool_weight);
    if (c.op == Op::Gains || c.op == Op::SetMode) ctl().set_gains(state_.s.gains());
    if (state_.s.run != v_.x.run_seen_) {
      v_.x.run_seen_ = state_.s.run;
      start_reference();
      v_.x.run_start_ = v_.x.ticks_;
      preview().new_reference();
      this->pace_arm(kPasses);
    }
    // The header once per start of the rows (tele on after off or plot).
    if (c.op == Op::Tele && state_.s.tele && !state_.s.plot && !rows_before) v_.x.header_due_ = true;
    if (Rig::train() && c.op == Op::Train) start_training(c.a);
    // A training run replaced by another command: its storage back to a generator.
    if (v_.x.training_ && !state_.s.training) {
      v_.x.training_ = false;
      start_reference();
      v_.x.run_start_ = v_.x.ticks_;
    }
  }

  // The board's scalars, all zero at boot (Zeroed: one memset). g_mm_ is set by construct().
  struct Scalars {
    LineStatus waiting_;     // Pending
    console::Op model_op_;   // Empty
    uint8_t model_key_;
    float model_a_;
    uint32_t ticks_;      // ticks processed
    uint32_t run_start_;  // tick at which the running reference started
    uint16_t run_seen_;
    uint16_t counts_;     // PWM counts of the last tick
    float g_mm_;          // stroke limit of pos/traj (the model's g, capped by the rig)
    T last_d_;            // the last compensated position (a mode change starts from it)
    bool training_;       // gen_ holds a Training (not a Gen)
    bool train_done_;     // "# train done" is due
    bool fault_due_;      // "# fault" is due
    bool header_due_;     // the telemetry header is due
  };
  // (The row slot after the scalars, zeroed with them: none on a board without the preview.)
  struct Vars : Scalars, detail::RowSlot<kPreview>, detail::FutureSlot<T, kLead> {};
  // Member order: AVR loads and stores reach 63 bytes past a pointer (ldd/std), farther fields
  // cost an address computation at each access. The fields the console and the tick read most
  // come first (the store, the scalars, then the state, whose hot settings lead it), the models
  // and the generator last (their own functions reach them through a pointer of their own):
  // measured -218 B of flash on the float image, -206 B on the Q16.16 one.
  storage::Store<Hw> store_;  // also the board's outputs (Hw)
  // From v_ to live_: zeroed by the constructor (one memset; keep them together).
  Zeroed<Vars> v_;
  StateStore state_;
  Zeroed<console::LineBuffer> line_;
  Zeroed<console::Reply> reply_;
  Zeroed<console::Live> live_;
  SafetyStore safety_;
  ModelStore models_;
  GenStore gen_;
};

}  // namespace sma

#endif  // SMA_BOARD_HPP
