// The memory budget of one solve (SolveOptions::memory_budget_mb, `--memory-budget MB`):
// a production method counts the bytes of its growing structures (BSP nodes and occluder
// lists, wedge BSP nodes and lists, shafts and their surfaces) against it and stops with
// MemoryBudgetExceeded instead of exhausting the machine (docs/formats.md, "solve").
//
// Guarantee: the counted bytes never exceed the budget by more than one growth step of
// one structure per thread (the check follows each growth). Not counted: the scene, the
// result and fixed-size scratch, so the process holds more than the counted bytes.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace visgate {

// Half of physical memory, at most 8 GiB (8192 MB); 8 GiB where the size is unknown.
inline uint64_t default_memory_budget_mb() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return 8192;
  return std::min<uint64_t>(8192, uint64_t(pages) / 2 * uint64_t(page) / (1024 * 1024));
}

// Thrown by a method whose counted structures would pass the budget. what(): one line
// naming the method, the budget and the structure; callers add the scene.
class MemoryBudgetExceeded : public std::runtime_error {
  static std::string megabytes(uint64_t bytes) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", double(bytes) / (1024.0 * 1024.0));
    return b;
  }

 public:
  MemoryBudgetExceeded(const std::string& method, uint64_t budget_mb, uint64_t held_bytes, const std::string& structure)
      : std::runtime_error(method + " stopped: its " + structure + " would hold " + megabytes(held_bytes) +
                           " MB, over the memory budget of " + std::to_string(budget_mb) +
                           " MB (--memory-budget MB raises it)"),
        method_(method),
        budget_mb_(budget_mb) {}
  const std::string& method() const { return method_; }
  uint64_t budget_mb() const { return budget_mb_; }

 private:
  std::string method_;
  uint64_t budget_mb_;
};

// The bytes one solve's counted structures hold, shared by its threads.
class MemoryBudget {
 public:
  // budget_mb 0: default_memory_budget_mb().
  MemoryBudget(std::string method, uint64_t budget_mb)
      : method_(std::move(method)), budget_mb_(budget_mb ? budget_mb : default_memory_budget_mb()),
        limit_(int64_t(std::min<uint64_t>(budget_mb_, uint64_t(1) << 40) * 1024 * 1024)) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // Adds `delta` bytes (negative: released). A growth that takes the total past the
  // budget throws MemoryBudgetExceeded naming `structure`; the bytes stay counted, so
  // the caller releases them as usual while unwinding.
  void change(int64_t delta, const char* structure) {
    const int64_t now = held_.fetch_add(delta, std::memory_order_relaxed) + delta;
    if (delta > 0 && now > limit_) throw MemoryBudgetExceeded(method_, budget_mb_, uint64_t(now), structure);
  }
  uint64_t budget_mb() const { return budget_mb_; }

 private:
  std::string method_;
  uint64_t budget_mb_;
  int64_t limit_;
  std::atomic<int64_t> held_{0};
};

// One structure's share of a budget: set() charges the change of its size, the
// destructor releases it. Unbound (the default) it does nothing.
class MemoryCharge {
 public:
  MemoryCharge() = default;
  MemoryCharge(const MemoryCharge&) = delete;
  MemoryCharge& operator=(const MemoryCharge&) = delete;
  ~MemoryCharge() { bind(nullptr, structure_); }
  // Releases the share held in the previous budget and charges the next ones there.
  void bind(MemoryBudget* budget, const char* structure) {
    if (budget_ && charged_) budget_->change(-int64_t(charged_), structure_);
    budget_ = budget;
    structure_ = structure;
    charged_ = 0;
  }
  void set(size_t bytes) {
    if (!budget_ || bytes == charged_) return;
    const int64_t delta = int64_t(bytes) - int64_t(charged_);
    charged_ = bytes;  // counted before a throw, released by the destructor
    budget_->change(delta, structure_);
  }

 private:
  MemoryBudget* budget_ = nullptr;
  const char* structure_ = "";
  size_t charged_ = 0;
};

}  // namespace visgate
