// The search of firmware/layout.py: the order of the Uno images' functions for the second link
// that keeps the most CALL/JMP within reach of a 2-byte RCALL/RJMP (+-4 KB). Simulated annealing
// on a fast score (below), the exact relaxation replayed every 1000 steps, many starts (the
// landscape has many local optima, +-25 B between seeds: more starts, a smaller image), the
// smallest exact size kept. layout.py reads the first link, writes the problem, runs this and
// replays the relaxation of the order it returns itself (the two must agree).
//
// Input (stdin, whitespace-separated integers; the arrays of layout.py's Layout):
//   n E m  raw_eff[n] end_ret[n] local[n] obj_id[n]  cu[E] co_fix[E] tu[E] to_fix[E] tidx[E]
//   gstart[n] gend[n]  order[m]
// Output (stdout): the best order found (m integers), then its exact .text size.
// usage: layout_anneal STEPS STARTS SEED < problem
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

// A CALL/JMP at `site` relaxes when -4094 <= target - site <= 4098 (binutils' avr_relax_section).
const int64_t kGapLo = -4094, kGapHi = 4098;

struct Problem {
  int n = 0, E = 0;
  std::vector<int64_t> raw_eff, cu, co_fix, tu, to_fix, tidx, gstart, gend;
  std::vector<int> end_ret, local, obj_id;
  std::vector<int> cross;  // edges between two units (the only ones an order changes)
};

// The second link's relaxation of `order`: unit sizes, call sites and targets at the fix point
// (a CALL made short moves everything after it by 2 bytes, which brings others into reach).
struct Relaxed {
  std::vector<int64_t> size, site, tgt;
  int64_t total = 0;
};

Relaxed relax(const Problem& p, const std::vector<int>& order) {
  const int n = p.n, E = p.E;
  std::vector<int> nxt(n);
  for (size_t k = 0; k + 1 < order.size(); ++k) nxt[order[k]] = order[k + 1];
  nxt[order.back()] = order.back();
  std::vector<int64_t> raw(n);
  for (int u = 0; u < n; ++u) {
    // A RET ending a unit survives when the next unit is a local function of the same object.
    const bool kept = p.obj_id[nxt[u]] == p.obj_id[u] && p.local[nxt[u]];
    raw[u] = p.raw_eff[u] - ((p.end_ret[u] && !kept) ? 2 : 0);
  }
  std::vector<char> R(E, 0);
  std::vector<int64_t> cs(E + 1), pos(n);
  Relaxed out;
  out.size.assign(n, 0);
  out.site.assign(E, 0);
  out.tgt.assign(E, 0);
  for (;;) {
    cs[0] = 0;
    for (int e = 0; e < E; ++e) cs[e + 1] = cs[e] + R[e];
    for (int u = 0; u < n; ++u) out.size[u] = raw[u] - 2 * (cs[p.gend[u]] - cs[p.gstart[u]]);
    int64_t at = 0;
    for (int u : order) {
      pos[u] = at;
      at += out.size[u];
    }
    bool changed = false;
    for (int e = 0; e < E; ++e) {
      const int64_t a = p.cu[e], b = p.tu[e];
      out.site[e] = pos[a] + p.co_fix[e] - 2 * (cs[e] - cs[p.gstart[a]]);
      out.tgt[e] = pos[b] + p.to_fix[e] - 2 * (cs[p.tidx[e]] - cs[p.gstart[b]]);
      const int64_t gap = out.tgt[e] - out.site[e];
      if (!R[e] && gap >= kGapLo && gap <= kGapHi) {
        R[e] = 1;
        changed = true;
      }
    }
    if (!changed) {
      out.total = at;
      return out;
    }
  }
}

// The search's fast score of orders near `order`: sizes and the call-site offsets within their
// units held at `order`'s; the calls in reach, plus half a call for each one out of reach, less
// the further it is (a smoother landscape for the annealing, which then finds more calls in reach).
struct Model {
  std::vector<int64_t> size, site_off, tgt_off;  // offsets: the cross edges'
  std::vector<int> cu, tu;
  mutable std::vector<int64_t> pos;
  int64_t total = 0;

  Model(const Problem& p, const std::vector<int>& order) {
    const Relaxed r = relax(p, order);
    size = r.size;
    total = r.total;
    std::vector<int64_t> at(p.n);
    int64_t a = 0;
    for (int u : order) {
      at[u] = a;
      a += size[u];
    }
    for (int e : p.cross) {
      cu.push_back(static_cast<int>(p.cu[e]));
      tu.push_back(static_cast<int>(p.tu[e]));
      site_off.push_back(r.site[e] - at[p.cu[e]]);
      tgt_off.push_back(r.tgt[e] - at[p.tu[e]]);
    }
    pos.assign(p.n, 0);
  }

  double score(const std::vector<int>& order) const {
    int64_t a = 0;
    for (int u : order) {
      pos[u] = a;
      a += size[u];
    }
    double s = 0.0;
    for (size_t k = 0; k < cu.size(); ++k) {
      const int64_t g = pos[tu[k]] + tgt_off[k] - pos[cu[k]] - site_off[k];
      int64_t out = -4094 - g;
      if (g - 4096 > out) out = g - 4096;  // relaxed, the displacement g - 2 lies in [-4096, 4094]
      s += out <= 0 ? 1.0 : 0.5 * std::exp(-static_cast<double>(out) / 300.0);
    }
    return s;
  }
};

// xorshift64*: the same sequence on every compiler and library (std's distributions are not).
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 1) {}
  uint64_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return s * 0x2545F4914F6CDD1Dull;
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  int below(int k) { return static_cast<int>(uniform() * k); }   // 0..k-1
  int range(int lo, int hi) { return lo + below(hi - lo); }       // lo..hi-1
};

// A move: two units swapped, or a run of 1..12 units moved elsewhere (half the time next to a
// unit the first one calls or is called by). Unit 0 (the fixed head) and the last (the tail) stay.
void move(Rng& rng, std::vector<int>& o, const std::vector<std::vector<int>>& partners) {
  const int m = static_cast<int>(o.size());
  const int i = rng.range(1, m - 1);
  if (rng.uniform() < 0.2) {
    const int j = rng.range(1, m - 1);
    const int t = o[i];
    o[i] = o[j];
    o[j] = t;
    return;
  }
  int len = 1 + rng.below(12);
  if (i + len > m - 1) len = m - 1 - i;
  std::vector<int> seg(o.begin() + i, o.begin() + i + len);
  o.erase(o.begin() + i, o.begin() + i + len);
  const int red = static_cast<int>(o.size());
  int j = -1;
  const std::vector<int>& ps = partners[seg[0]];
  if (rng.uniform() < 0.5 && !ps.empty()) {
    const int v = ps[rng.below(static_cast<int>(ps.size()))];
    for (int k = 0; k < red; ++k)
      if (o[k] == v) j = k;
    if (j >= 0) {
      j += rng.range(-2, 4);
      if (j < 1) j = 1;
      if (j > red - 1) j = red - 1;
    }
  }
  if (j < 0) j = rng.range(1, red);
  o.insert(o.begin() + j, seg.begin(), seg.end());
}

// One annealing run from `start` (a fixed seed: the same first link gives the same order):
// move()s scored by the Model, a worse order accepted with a probability that falls; the model
// re-measured every 1000 steps, the smallest exact size seen kept.
std::vector<int> anneal(const Problem& p, const std::vector<int>& start, long steps, uint64_t seed,
                        const std::vector<std::vector<int>>& partners, int64_t* best_size) {
  Rng rng(seed);
  std::vector<int> cur = start, best = start, o;
  *best_size = -1;
  const double t0 = 3.0, t1 = 0.05;
  Model model(p, cur);
  double cur_s = 0.0;
  for (long step = 0; step <= steps; ++step) {
    if (step % 1000 == 0 || step == steps) {
      model = Model(p, cur);
      if (*best_size < 0 || model.total < *best_size) {
        *best_size = model.total;
        best = cur;
      }
      cur_s = model.score(cur);
      if (step == steps) break;
    }
    const double temp = t0 * std::pow(t1 / t0, static_cast<double>(step) / static_cast<double>(steps));
    o = cur;
    move(rng, o, partners);
    const double s = model.score(o);
    if (s >= cur_s || rng.uniform() < std::exp((s - cur_s) / temp)) {
      cur_s = s;
      cur.swap(o);
    }
  }
  return best;
}

bool read(std::vector<int64_t>& v, int k) {
  v.resize(k);
  for (int i = 0; i < k; ++i) {
    long long x = 0;
    if (std::scanf("%lld", &x) != 1) return false;
    v[i] = x;
  }
  return true;
}
bool read(std::vector<int>& v, int k) {
  v.resize(k);
  for (int i = 0; i < k; ++i)
    if (std::scanf("%d", &v[i]) != 1) return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: layout_anneal STEPS STARTS SEED < problem\n");
    return 2;
  }
  const long steps = std::atol(argv[1]);
  const int starts = std::atoi(argv[2]);
  const uint64_t seed = std::strtoull(argv[3], nullptr, 10);
  Problem p;
  int m = 0;
  std::vector<int> order;
  if (std::scanf("%d %d %d", &p.n, &p.E, &m) != 3 || p.n < 2 || p.E < 0 || m != p.n ||
      !read(p.raw_eff, p.n) || !read(p.end_ret, p.n) || !read(p.local, p.n) || !read(p.obj_id, p.n) ||
      !read(p.cu, p.E) || !read(p.co_fix, p.E) || !read(p.tu, p.E) || !read(p.to_fix, p.E) ||
      !read(p.tidx, p.E) || !read(p.gstart, p.n) || !read(p.gend, p.n) || !read(order, m)) {
    std::fprintf(stderr, "layout_anneal: malformed problem on stdin\n");
    return 2;
  }
  // Every index within its array, the order a permutation of the units: an out-of-range index
  // would read past an array, a repeated unit would lose one.
  bool ok = true;
  for (int e = 0; e < p.E; ++e)
    ok = ok && p.cu[e] >= 0 && p.cu[e] < p.n && p.tu[e] >= 0 && p.tu[e] < p.n && p.tidx[e] >= 0 && p.tidx[e] <= p.E;
  std::vector<char> seen(p.n, 0);
  for (int u = 0; u < p.n; ++u) {
    ok = ok && p.gstart[u] >= 0 && p.gstart[u] <= p.gend[u] && p.gend[u] <= p.E && p.obj_id[u] >= 0;
    ok = ok && order[u] >= 0 && order[u] < p.n && !seen[order[u]];
    if (ok) seen[order[u]] = 1;
  }
  if (!ok) {
    std::fprintf(stderr, "layout_anneal: an index out of range, or an order that is not a permutation\n");
    return 2;
  }
  std::vector<std::vector<int>> partners(p.n);
  for (int e = 0; e < p.E; ++e) {
    if (p.cu[e] == p.tu[e]) continue;
    p.cross.push_back(e);
    partners[p.cu[e]].push_back(static_cast<int>(p.tu[e]));
    partners[p.tu[e]].push_back(static_cast<int>(p.cu[e]));
  }
  std::vector<int> best = order;
  int64_t best_size = relax(p, order).total;
  for (int k = 0; k < starts; ++k) {
    int64_t size = 0;
    const std::vector<int> o = anneal(p, order, steps, seed + static_cast<uint64_t>(k), partners, &size);
    if (size < best_size) {
      best_size = size;
      best = o;
    }
  }
  for (int u : best) std::printf("%d ", u);
  std::printf("\n%lld\n", static_cast<long long>(best_size));
  return 0;
}
