// The host's one driver of sma::Board (sma/board.hpp): the board's logic, unchanged, against a
// simulated plant, as the firmware's main.cpp drives it on the Uno.
//
//   plant --(sensor mm -> the rig's calibration inverted -> volts -> 10-bit ADC counts, one
//            sample per sample_s, summed over the tick with the out-of-range count)--> control()
//   control() -> PWM counts n -> V = V_supply sqrt(n / (TOP + 1)), held over the next tick
//   console lines in (send()), reply / telemetry lines out (collected, and to an optional sink)
//   the EEPROM: 1 KB of RAM (eeprom(): load or save it around a run)
//
// Used by the virtual rig's --native mode (tools/vrig/vrig.cpp), `sma sim` (tools/host/sma_sim.cpp)
// and the tests: one host driver of the Board, so none of them keeps its own glue.
#ifndef SMA_HOST_BOARD_LOOP_HPP
#define SMA_HOST_BOARD_LOOP_HPP

#include <math.h>
#include <stdint.h>
#include <string.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sma/board.hpp"

namespace sma_host {

// What the board writes and stores, on the host.
struct BoardIo {
  uint8_t eeprom[1024];
  std::function<void(const char*, uint8_t)> line;
};
// The Board's Hw (board.hpp): lines to the harness, the EEPROM in RAM, no interrupts.
struct BoardHw {
  BoardIo* io;
  bool line(const char* s, uint8_t len) {
    io->line(s, len);
    return true;
  }
  uint8_t read(uint16_t a) const { return a < sizeof io->eeprom ? io->eeprom[a] : 0xFF; }
  void write(uint16_t a, uint8_t v) {
    if (a < sizeof io->eeprom) io->eeprom[a] = v;
  }
  uint8_t irq_off() { return 0; }
  void irq_restore(uint8_t) {}
};

struct BoardLoopOptions {
  double sample_s = 1e-3;     // the ADC's sample period; the plant steps at it
  double fault_at_s = -1.0;   // >= 0: from this tick on the sensor pin reads fault_mv (sensor lost)
  double fault_mv = 5000.0;
};

template <class Rig, class PlantT>
class BoardLoop {
 public:
  typedef sma::Board<float, Rig, BoardHw> Board;
  static constexpr double kDt = 1.0 / Rig::tick_hz();

  struct Tick {
    double t;         // the tick's start, s (its telemetry row's t_s)
    uint16_t counts;  // PWM counts written
    double v;         // the voltage they apply over the next tick, V
  };

  // Lines the board writes, with the time of the tick they belong to.
  typedef std::function<void(double t, const std::string& line)> Sink;

  explicit BoardLoop(PlantT& plant, const BoardLoopOptions& o = BoardLoopOptions())
      : plant_(plant), opt_(o), sub_(static_cast<int>(kDt / o.sample_s + 0.5)) {
    memset(io_.eeprom, 0xFF, sizeof io_.eeprom);  // an erased EEPROM
    io_.line = [this](const char* s, uint8_t len) {
      const std::string l(s, len);
      lines_.push_back(l);
      if (sink_) sink_(t_, l);
    };
    board_.reset(new Board(BoardHw{&io_}));
  }
  BoardLoop(const BoardLoop&) = delete;
  BoardLoop& operator=(const BoardLoop&) = delete;

  void set_sink(Sink s) { sink_ = s; }
  // The 1 KB EEPROM: fill it before boot() (a saved image), read it after the run.
  uint8_t* eeprom() { return io_.eeprom; }
  Board& board() { return *board_; }
  PlantT& plant() { return plant_; }
  double time() const { return t_; }  // the next tick's start

  // Reset: the models from the EEPROM, the banner (a watchdog reset announces its fault).
  void boot(bool watchdog_reset = false, const char* banner = "# ready") { board_->boot(watchdog_reset, banner); }

  // Bytes in as the UART delivers them; every completed line handled at once (the firmware
  // defers a line by at most one tick). Returns the lines the board wrote meanwhile.
  std::vector<std::string> send_bytes(const std::string& bytes) {
    lines_.clear();
    for (char c : bytes) {
      if (!board_->rx(c)) continue;
      board_->handle_line();
      if (board_->model_pending()) board_->run_model_op();
      board_->poll();
      while (!board_->plan()) {  // a restarted preview's passes (Board::plan()), as main.cpp's loop
      }
    }
    return lines_;
  }
  // One console line; its reply (the last line it wrote, "" if none).
  std::string send(const std::string& line) {
    const std::vector<std::string> out = send_bytes(line + "\n");
    return out.empty() ? std::string() : out.back();
  }

  // One tick: the plant runs one tick at the held voltage while the ADC samples it, then the
  // board's control section on those samples, its report, and the idle work before the next:
  // the preview's plan until the tick's planning is done (Board::plan(): Board::plan_passes(), the
  // firmware's rule too).
  Tick tick() {
    uint32_t sum = 0;
    uint8_t n = 0, bad = 0;
    for (int j = 0; j < sub_; ++j) {
      plant_.step(v_, opt_.sample_s);
      if (on_sample) on_sample(t_ + (j + 1) * opt_.sample_s);
      double mv = sensor_mv(plant_.measure());
      if (opt_.fault_at_s >= 0.0 && t_ >= opt_.fault_at_s) mv = opt_.fault_mv;
      const uint16_t a = adc_counts(mv);
      sum += a;
      ++n;
      if (a < kAdcLo || a > kAdcHi) ++bad;
    }
    Tick k;
    k.t = t_;
    k.counts = board_->control(sum, n, bad);
    v_ = pwm_volts(k.counts);
    k.v = v_;
    board_->report();
    board_->poll();
    while (!board_->plan()) {
    }
    ++ticks_;
    t_ = static_cast<double>(ticks_) * kDt;
    return k;
  }

  // Called after each plant sample step with its time (e.g. the wire's true displacement).
  std::function<void(double t)> on_sample;

  // The rig's calibration inverted: millivolts on the sensor pin for a displacement (the pin
  // cannot leave 0..Vref).
  static double sensor_mv(double mm) {
    const double v = (mm - Rig::sensor_offset_mm()) / Rig::sensor_mm_per_v();
    return sma::clamp(v, 0.0, Rig::adc_vref()) * 1000.0;
  }
  // The ADC's conversion of a pin voltage (truncating, 0..counts-1).
  static uint16_t adc_counts(double mv) {
    double c = floor(mv / (Rig::adc_vref() * 1000.0) * Rig::adc_counts());
    c = c < 0 ? 0 : c > Rig::adc_counts() - 1 ? Rig::adc_counts() - 1 : c;
    return static_cast<uint16_t>(c);
  }
  // PWM counts -> the effective voltage on the wire (duty n / (TOP + 1) = (V / V_supply)^2).
  static double pwm_volts(uint16_t counts) { return Rig::v_supply() * sqrt(counts / (Rig::pwm_top() + 1.0)); }

  // ADC counts of the sensor's valid range (main.cpp's): outside it a sample counts as bad.
  static constexpr uint16_t kAdcLo = static_cast<uint16_t>(Rig::sensor_v_min() / Rig::adc_vref() * Rig::adc_counts() + 0.5);
  static constexpr uint16_t kAdcHi = static_cast<uint16_t>(Rig::sensor_v_max() / Rig::adc_vref() * Rig::adc_counts() + 0.5);

 private:
  PlantT& plant_;
  BoardLoopOptions opt_;
  int sub_;
  BoardIo io_;
  std::unique_ptr<Board> board_;
  std::vector<std::string> lines_;
  Sink sink_;
  double v_ = 0.0;  // the PWM's voltage, held between ticks
  double t_ = 0.0;
  long ticks_ = 0;
};

template <class Rig, class PlantT>
constexpr double BoardLoop<Rig, PlantT>::kDt;
template <class Rig, class PlantT>
constexpr uint16_t BoardLoop<Rig, PlantT>::kAdcLo;
template <class Rig, class PlantT>
constexpr uint16_t BoardLoop<Rig, PlantT>::kAdcHi;

}  // namespace sma_host

#endif  // SMA_HOST_BOARD_LOOP_HPP
