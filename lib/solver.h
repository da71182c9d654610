// The one interface every visibility method implements (DESIGN section 4), the method
// registry, and the result JSON (format "visgate-result").
//
// A method answers every relation (receiver i, sample j of light l) of a scene, where
// the light point is sample_position(light, j, i). Bits are light-major: relation
// (l, j) of a receiver is bit light_offset(l) + j. A method measures its own `seconds`:
// the solve including its acceleration structures, excluding file loading and mesh
// preparation (which it reports in stats as "prepare_seconds" when it has any).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "lib/base/result.h"
#include "lib/scene/scene.h"

namespace visgate {

using Polygon3f = std::vector<Vec3f>;

// Named figures of one solve. Names are interned: one process-wide copy of each, made
// the first time any Stats uses it (stats_key), so setting a figure allocates nothing
// once its name is known (a method sets 20 to 60 per solve, most longer than the
// short-string buffer). Entries stay in the order they were first set and are found by
// the interned name's address, so set() and add() compare no strings (string compares
// showed up in fuzz profiles: docs/log/fuzzing.md). sorted() gives them by name for
// output.
std::string_view stats_key(std::string_view name);

struct Stats {
  using Entry = std::pair<std::string_view, double>;
  void set(std::string_view k, double v) { slot(k) = v; }
  void add(std::string_view k, double v) { slot(k) += v; }
  const Entry* find(std::string_view k) const {
    for (const Entry& e : values_)
      if (e.first == k) return &e;
    return nullptr;
  }
  double get(std::string_view k, double fallback = 0.0) const {
    const Entry* e = find(k);
    return e ? e->second : fallback;
  }
  // The entries sorted by name.
  std::vector<Entry> sorted() const;

 private:
  double& slot(std::string_view k) {
    const std::string_view key = stats_key(k);
    for (auto it = values_.rbegin(); it != values_.rend(); ++it)
      if (it->first.data() == key.data()) return it->second;
    return values_.emplace_back(key, 0.0).second;
  }
  std::vector<Entry> values_;  // in order of first use; names from stats_key (they outlive every Stats)
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
  // Whether solve() hands solve_scene the scene's unit copy (lib/scene/exact_transform.h:
  // scaled by the power of two that brings its unit length into [2, 4)). True for the
  // production methods, so that they answer a scene and each of its exact 2^k copies
  // with the same bits (DESIGN section 2, "Scale"); the baselines (embree,
  // embree-robust, brute) answer the scene as given, as their users run them.
  virtual bool normalises_scale() const { return true; }

  // Answers every relation of `scene`. With normalises_scale(), the method solves the
  // unit copy; bits and fractions are scale-free, fragments are scaled back (exactly,
  // unless a vertex falls below float32's normal range), `seconds` includes the copy,
  // and stats "scale_exponent" holds the k applied (0: none).
  SolveResult solve(const Scene& scene, const SolveOptions& opt);

  // Rejects unknown options and values outside the spec; messages name the option.
  Status check_options(const SolveOptions& opt) const;
  // The same against `specs`, this method's options() built once by the caller (the fuzz
  // targets check every input's options; building the list was 3.6% of fuzz_iss's
  // allocations).
  Status check_options(const SolveOptions& opt, const std::vector<OptionSpec>& specs) const;

 protected:
  // The method itself, on the scene solve() chose (the unit copy or the input).
  virtual SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) = 0;
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
