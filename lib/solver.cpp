// Solver interface helpers: option checking, result allocation, the result JSON and
// the TBB thread limit.
#include "lib/solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>

#include <tbb/global_control.h>

#include "lib/scene/exact_transform.h"
#include "lib/scene/json_writer.h"


namespace visgate {

namespace {

std::string_view intern_stats_name(std::string_view name) {
  static std::mutex mutex;
  static std::set<std::string, std::less<>> names;  // nodes never move: the views stay valid
  std::lock_guard<std::mutex> lock(mutex);
  auto it = names.find(name);
  if (it == names.end()) it = names.emplace(name).first;
  return *it;
}

}  // namespace

// Names are mostly string literals, whose addresses do not change: a per-thread table
// keyed by the name's address answers them with one comparison of the contents (needed:
// a name built in a temporary string may reuse an address with other text). The
// address is hashed (Fibonacci) into 256 sets of two slots, the most recent first:
// literals lie next to each other, so the low address bits alone would crowd a few sets;
// two slots because one per set still missed several times per solve.
std::string_view stats_key(std::string_view name) {
  struct Slot {
    const char* data = nullptr;
    std::string_view interned;
  };
  thread_local Slot table[256][2];
  const uint64_t h = uint64_t(reinterpret_cast<uintptr_t>(name.data())) * 0x9E3779B97F4A7C15ull;
  Slot* set = table[h >> 56];
  if (set[0].data == name.data() && set[0].interned == name) return set[0].interned;
  if (set[1].data == name.data() && set[1].interned == name) return set[1].interned;
  set[1] = set[0];
  set[0] = Slot{name.data(), intern_stats_name(name)};
  return set[0].interned;
}

std::vector<Stats::Entry> Stats::sorted() const {
  std::vector<Entry> v = values_;
  std::sort(v.begin(), v.end(), [](const Entry& a, const Entry& b) { return a.first < b.first; });
  return v;
}

long SolveOptions::get_int(const std::string& k, long fallback) const {
  auto it = opts.find(k);
  if (it == opts.end()) return fallback;
  try {
    return std::stol(it->second);
  } catch (...) {
    return fallback;
  }
}

bool SolveOptions::get_bool(const std::string& k, bool fallback) const {
  auto it = opts.find(k);
  if (it == opts.end()) return fallback;
  const std::string& v = it->second;
  if (v == "on" || v == "true" || v == "1") return true;
  if (v == "off" || v == "false" || v == "0") return false;
  return fallback;
}

SolveResult Solver::solve(const Scene& scene, const SolveOptions& opt) {
  const int k = normalises_scale() ? unit_scale_exponent(scene) : 0;
  if (k == 0) {
    SolveResult r = solve_scene(scene, opt);
    if (normalises_scale()) r.stats.set("scale_exponent", 0.0);
    return r;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const Scene unit = scaled_scene(scene, k);
  const double copy_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  SolveResult r = solve_scene(unit, opt);
  for (auto& rr : r.receivers)
    for (auto& per_light : rr.fragments)
      for (auto& poly : per_light)
        for (auto& p : poly)
          for (int a = 0; a < 3; ++a) p[a] = float(std::ldexp(double(p[a]), -k));
  r.seconds += copy_seconds;
  r.stats.set("scale_exponent", double(k));
  return r;
}

Status Solver::check_options(const SolveOptions& opt) const { return check_options(opt, options()); }

Status Solver::check_options(const SolveOptions& opt, const std::vector<OptionSpec>& specs) const {
  for (const auto& [k, v] : opt.opts) {
    const OptionSpec* spec = nullptr;
    for (const auto& s : specs)
      if (s.name == k) spec = &s;
    if (!spec) {
      std::string known;
      for (const auto& s : specs) known += (known.empty() ? "" : ", ") + s.name;
      return Error{"--opt " + k + ": unknown option for method " + name() + (known.empty() ? " (it has none)" : " (known: " + known + ")")};
    }
    if (spec->values.empty()) {
      size_t pos = 0;
      long x = 0;
      try {
        x = std::stol(v, &pos);
      } catch (...) {
        pos = 0;
      }
      if (pos != v.size() || v.empty() || x < 0) return Error{"--opt " + k + "=" + v + ": expected a non-negative integer"};
    } else {
      bool found = false;
      for (const auto& a : spec->values) found |= (a == v);
      if (!found) {
        std::string allowed;
        for (const auto& a : spec->values) allowed += (allowed.empty() ? "" : "|") + a;
        return Error{"--opt " + k + "=" + v + ": expected " + allowed};
      }
    }
  }
  return {};
}

SolveResult make_empty_result(const Scene& scene) {
  SolveResult r;
  size_t bits = scene.samples_per_receiver();
  r.receivers.resize(scene.receivers.size());
  for (auto& rr : r.receivers) {
    rr.visible_bits.assign((bits + 63) / 64, 0);
    rr.visible_fraction.assign(scene.lights.size(), 0.0f);
  }
  return r;
}

size_t ReceiverResult::count_visible(size_t begin, size_t end) const {
  if (begin >= end) return 0;
  const size_t w0 = begin >> 6, w1 = (end - 1) >> 6;
  const uint64_t first = ~uint64_t(0) << (begin & 63);               // bits >= begin in word w0
  const uint64_t last = ~uint64_t(0) >> (63 - ((end - 1) & 63));     // bits <= end - 1 in word w1
  if (w0 == w1) return size_t(__builtin_popcountll(visible_bits[w0] & first & last));
  size_t n = size_t(__builtin_popcountll(visible_bits[w0] & first)) + size_t(__builtin_popcountll(visible_bits[w1] & last));
  for (size_t w = w0 + 1; w < w1; ++w) n += size_t(__builtin_popcountll(visible_bits[w]));
  return n;
}

void fractions_from_bits(const Scene& scene, SolveResult& result) {
  for (auto& rr : result.receivers) {
    size_t off = 0;
    for (size_t l = 0; l < scene.lights.size(); ++l) {
      size_t n = size_t(scene.lights[l].samples), vis = rr.count_visible(off, off + n);
      rr.visible_fraction[l] = float(double(vis) / double(n));
      off += n;
    }
  }
}

namespace {

// An upper bound of the result text's length, so that the output is allocated once
// (escaping grows a string at most sixfold: one byte becomes a six-character escape).
size_t result_json_bound(const Scene& scene, const std::string& method, const SolveOptions& opt,
                         const std::vector<Stats::Entry>& stats, const SolveResult& result) {
  constexpr size_t num = JsonWriter::kMaxDoubleChars + 1;  // a number and its comma
  size_t n = 256 + 6 * method.size();
  for (const auto& [k, v] : opt.opts) n += 6 * (k.size() + v.size()) + 8;
  for (const auto& [k, v] : stats) n += 6 * k.size() + 4 + num;
  const size_t bits = scene.samples_per_receiver();
  for (const auto& rr : result.receivers) {
    n += 64 + bits + rr.visible_fraction.size() * num;
    for (const auto& per_light : rr.fragments) {
      n += 3;
      for (const auto& poly : per_light) n += 3 + poly.size() * (3 * num + 3);
    }
  }
  return n;
}

}  // namespace

// Streams the document ordered_json would build, {format, version, method, options, seed,
// receivers: [{visible, visible_fraction, fragments?}], stats, seconds}, byte for byte
// (tests/scene/json_writer_test.cpp keeps the DOM writer as the reference). Building,
// dumping and freeing the DOM was 15% of `visgate solve` on the bunny with plucker-bsp.
std::string write_result_json(const Scene& scene, const std::string& method, const SolveOptions& opt,
                              const SolveResult& result) {
  const std::vector<Stats::Entry> stats = result.stats.sorted();
  std::string out;
  out.reserve(result_json_bound(scene, method, opt, stats, result));
  JsonWriter w(out);
  w.raw("{\"format\":\"visgate-result\",\"version\":1,\"method\":");
  w.value(method);
  w.raw(",\"options\":");
  w.object(opt.opts);  // a std::map: unique keys, in order
  w.raw(",\"seed\":");
  w.value(opt.seed);
  w.raw(",\"receivers\":[");
  const size_t bits = scene.samples_per_receiver();
  for (size_t i = 0; i < result.receivers.size(); ++i) {
    const ReceiverResult& rr = result.receivers[i];
    w.raw(i ? ",{\"visible\":\"" : "{\"visible\":\"");
    for (size_t b = 0; b < bits; ++b) w.raw(rr.visible(b) ? '1' : '0');  // '0' and '1' need no escaping
    w.raw("\",\"visible_fraction\":[");
    for (size_t l = 0; l < rr.visible_fraction.size(); ++l) {
      if (l) w.raw(',');
      w.value(double(rr.visible_fraction[l]));
    }
    w.raw(']');
    if (!rr.fragments.empty()) {
      w.raw(",\"fragments\":[");
      for (size_t l = 0; l < rr.fragments.size(); ++l) {
        w.raw(l ? ",[" : "[");
        for (size_t k = 0; k < rr.fragments[l].size(); ++k) {
          w.raw(k ? ",[" : "[");
          const Polygon3f& poly = rr.fragments[l][k];
          for (size_t j = 0; j < poly.size(); ++j) {
            if (j) w.raw(',');
            w.point(double(poly[j].x), double(poly[j].y), double(poly[j].z));
          }
          w.raw(']');
        }
        w.raw(']');
      }
      w.raw(']');
    }
    w.raw('}');
  }
  w.raw("],\"stats\":");
  w.object(stats);  // unique keys: Stats keeps one entry per interned name
  w.raw(",\"seconds\":");
  w.value(result.seconds);
  w.raw("}\n");
  return out;
}

#ifdef CGAL_HAS_NO_THREADS
// A build with CGAL's thread safety off (CMake option VISGATE_CGAL_NO_THREADS, the fuzz
// builds) runs everything on one thread: TBB takes the smallest active limit, so every
// ThreadLimit below and every parallel loop without one stays serial.
namespace {
const tbb::global_control single_threaded_build(tbb::global_control::max_allowed_parallelism, 1);
}  // namespace
#endif

ThreadLimit::ThreadLimit(int threads) : impl_(nullptr) {
  if (threads > 0) impl_ = new tbb::global_control(tbb::global_control::max_allowed_parallelism, size_t(threads));
}
ThreadLimit::~ThreadLimit() { delete static_cast<tbb::global_control*>(impl_); }

}  // namespace visgate
