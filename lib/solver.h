// The one interface every visibility method implements (DESIGN section 4), the method
// registry, and the result JSON (format "visgate-result").
//
// A method answers every relation (receiver i, sample j of light l) of a scene, where
// the light point is sample_position(light, j, i). Bits are light-major: relation
// (l, j) of a receiver is bit light_offset(l) + j. A method measures its own `seconds`:
// the solve including its acceleration structures, excluding file loading and mesh
// preparation (which it reports in stats as "prepare_seconds" when it has any).
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "lib/scene/error.h"
#include "lib/scene/scene.h"

namespace visgate {

using Polygon3f = std::vector<Vec3f>;

// Named figures of one solve, sorted by name. Names are interned: one process-wide copy
// of each, made the first time any Stats uses it (stats_key), so setting a figure
// allocates nothing once its name is known. A method sets 20 to 60 of them per solve,
// most longer than the short-string buffer: as a std::map of std::string they were 17%
// of fuzz_iss's allocations and 2.6% of fuzz_plucker's (ASan's allocator is a quarter
// to a third of those targets' samples; 2026-12-03), and before the transparent lookup
// the temporaries 3.5% of fuzz_iss's time (2026-12-02).
std::string_view stats_key(std::string_view name);

struct Stats {
  using Entry = std::pair<std::string_view, double>;
  std::vector<Entry> values;  // sorted by name; names from stats_key (they outlive every Stats)
  void set(std::string_view k, double v) { slot(k) = v; }
  void add(std::string_view k, double v) { slot(k) += v; }
  const Entry* find(std::string_view k) const {
    auto it = position(values, k);
    return it != values.end() && it->first == k ? &*it : nullptr;
  }
  double get(std::string_view k, double fallback = 0.0) const {
    const Entry* e = find(k);
    return e ? e->second : fallback;
  }

 private:
  // The first entry whose name is not below k.
  template <class V>
  static auto position(V& v, std::string_view k) -> decltype(v.begin()) {
    return std::lower_bound(v.begin(), v.end(), k, [](const Entry& e, std::string_view x) { return e.first < x; });
  }
  double& slot(std::string_view k) {
    auto it = position(values, k);
    if (it == values.end() || it->first != k) it = values.insert(it, Entry{stats_key(k), 0.0});
    return it->second;
  }
};

struct SolveOptions {
  std::map<std::string, std::string> opts;
  uint64_t seed = 1;
  int threads = 0;  // 0: all hardware threads

  std::string get(const std::string& k, const std::string& fallback) const {
    auto it = opts.find(k);
    return it == opts.end() ? fallback : it->second;
  }
  // Integer option; throws nothing: returns fallback when absent (validated earlier).
  long get_int(const std::string& k, long fallback) const;
  bool get_bool(const std::string& k, bool fallback) const;  // on/off, true/false, 1/0
};

struct ReceiverResult {
  std::vector<uint64_t> visible_bits;           // one bit per (light, sample), light-major
  std::vector<float> visible_fraction;          // per light
  std::vector<std::vector<Polygon3f>> fragments;  // per light; exact methods only

  bool visible(size_t bit) const { return (visible_bits[bit >> 6] >> (bit & 63)) & 1u; }
  void set_visible(size_t bit, bool v) {
    if (v) visible_bits[bit >> 6] |= uint64_t(1) << (bit & 63);
    else visible_bits[bit >> 6] &= ~(uint64_t(1) << (bit & 63));
  }
  // Visible bits in [begin, end), a popcount per 64-bit word (the bit-by-bit count was
  // 16% of ISS's instructions on rooms: 616M relations, ~9 instructions each).
  size_t count_visible(size_t begin, size_t end) const;
};

struct SolveResult {
  std::vector<ReceiverResult> receivers;
  Stats stats;
  double seconds = 0.0;
};

// Allocates one ReceiverResult per receiver with all bits clear.
SolveResult make_empty_result(const Scene& scene);
// visible_fraction[l] = visible samples of light l / samples of light l, for bit methods.
void fractions_from_bits(const Scene& scene, SolveResult& result);

struct OptionSpec {
  std::string name;
  std::string help;
  std::vector<std::string> values;  // allowed values; empty: any integer
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual std::string name() const = 0;
  virtual std::vector<OptionSpec> options() const { return {}; }
  virtual bool reports_fragments() const { return false; }
  virtual SolveResult solve(const Scene& scene, const SolveOptions& opt) = 0;

  // Rejects unknown options and values outside the spec; messages name the option.
  Status check_options(const SolveOptions& opt) const;
};

// Registry: every method name of DESIGN section 4 that is built in.
std::vector<std::string> solver_names();
std::unique_ptr<Solver> make_solver(const std::string& name);  // nullptr when unknown

// Result JSON (DESIGN section 4).
std::string write_result_json(const Scene& scene, const std::string& method, const SolveOptions& opt,
                              const SolveResult& result);

// Sets TBB's thread count for the lifetime of the returned object (0: all threads).
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  void* impl_;
};

}  // namespace visgate
