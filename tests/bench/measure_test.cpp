// tools/bench/measure: paired rounds and their ratios, the sweep budget and each run's
// peak memory. No timing is asserted: the solvers report scripted times.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <string>

#include "tools/bench/measure.h"

namespace visgate::bench {
namespace {

TEST(BenchRoundRatios, HandComputedPairedRounds) {
  // Rounds: 4/2 = 2, 3/2 = 1.5, 6/4 = 1.5, 10/4 = 2.5; sorted 1.5 1.5 2 2.5, median 1.75.
  // Minima 3 and 2: 1.5 (a slow round of the base alone would move it, not the median).
  RoundRatios r = round_ratios({2, 2, 4, 4}, {4, 3, 6, 10});
  EXPECT_DOUBLE_EQ(r.of_minima, 1.5);
  EXPECT_DOUBLE_EQ(r.median, 1.75);
  EXPECT_DOUBLE_EQ(r.lo, 1.5);
  EXPECT_DOUBLE_EQ(r.hi, 2.5);
  RoundRatios odd = round_ratios({1, 2, 4}, {3, 2, 6});  // 3, 1, 1.5
  EXPECT_DOUBLE_EQ(odd.median, 1.5);
  EXPECT_DOUBLE_EQ(odd.of_minima, 2.0);
  EXPECT_TRUE(std::isnan(round_ratios({}, {}).median));
  EXPECT_TRUE(std::isnan(round_ratios({1, 2}, {1}).of_minima));
}

// A solver that reports scripted times and logs which scene and options it was given.
class Scripted : public Solver {
 public:
  Scripted(std::string name, std::vector<double> times, std::vector<std::string>* log)
      : name_(std::move(name)), times_(std::move(times)), log_(log) {}
  std::string name() const override { return name_; }
  bool normalises_scale() const override { return false; }  // its scripted times are the whole solve

 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override {
    log_->push_back(name_ + ":" + scene.name + ":" + opt.get("k", "-") + ":" + std::to_string(opt.threads));
    SolveResult r;
    r.seconds = times_.at(calls_++);
    return r;
  }

 private:
  std::string name_;
  std::vector<double> times_;
  std::vector<std::string>* log_;
  size_t calls_ = 0;
};

TEST(BenchPaired, AlternatesTheTwoSolversOnTheirOwnScenesSingleThreaded) {
  std::vector<std::string> log;
  // Round 2 is a slow phase for both (x2): the ratio of the minima and the median of the
  // per-round ratios stay at 3, where back-to-back minima of b in that phase would not.
  Scripted a("a", {0.30, 0.60, 0.33}, &log), b("b", {0.10, 0.20, 0.11}, &log);
  Scene sa, sb;
  sa.name = "big";
  sb.name = "small";
  SolveOptions oa, ob;
  oa.threads = ob.threads = 4;  // overridden: every paired run is single-threaded
  ob.opts["k"] = "v";
  MeasureConfig cfg;
  cfg.repeat = 5;  // ignored: one run per solver and round
  const MeasureConfig one = single_run(cfg);
  EXPECT_EQ(one.repeat, 1);
  EXPECT_TRUE(one.single);
  EXPECT_FALSE(one.all);
  EXPECT_EQ(one.budget, cfg.budget);
  PairedTimes t = measure_paired(a, sa, oa, b, sb, ob, 3, cfg);
  const std::vector<std::string> want = {"a:big:-:1", "b:small:v:1", "a:big:-:1",
                                         "b:small:v:1", "a:big:-:1", "b:small:v:1"};
  EXPECT_EQ(log, want);
  EXPECT_EQ(t.a_seconds, (std::vector<double>{0.30, 0.60, 0.33}));
  EXPECT_EQ(t.b_seconds, (std::vector<double>{0.10, 0.20, 0.11}));
  ASSERT_EQ(t.a_cpu.size(), 3u);
  for (double c : t.a_cpu) EXPECT_GE(c, 0.0);
  RoundRatios r = round_ratios(t.b_seconds, t.a_seconds);
  EXPECT_NEAR(r.of_minima, 3.0, 1e-12);
  EXPECT_NEAR(r.median, 3.0, 1e-12);
  EXPECT_TRUE(measure_paired(a, sa, oa, b, sb, ob, 0, cfg).a_seconds.empty());
  // A run beyond the budget ends the rounds after its own.
  log.clear();
  Scripted c("c", {1.0, 9.0, 1.0}, &log), d("d", {0.5, 0.5, 0.5}, &log);
  cfg.budget = 5.0;
  PairedTimes cut = measure_paired(c, sa, oa, d, sb, ob, 3, cfg);
  EXPECT_EQ(cut.a_seconds, (std::vector<double>{1.0, 9.0}));
  EXPECT_EQ(cut.b_seconds, (std::vector<double>{0.5, 0.5}));
  EXPECT_EQ(log.size(), 4u);
}

TEST(BenchSweepGuard, PredictsLinearlyFromTheLastPoint) {
  SweepGuard g(10.0);
  std::string why;
  EXPECT_FALSE(g.skip("brute", 4, &why));  // nothing measured yet
  g.record("brute", 4, 2.0);
  EXPECT_FALSE(g.skip("brute", 16, &why));  // 2 s * 16/4 = 8 s <= 10 s
  EXPECT_TRUE(g.skip("brute", 64, &why));   // 32 s > 10 s
  EXPECT_NE(why.find("32.0 s"), std::string::npos) << why;
  EXPECT_FALSE(g.skip("embree", 64, &why));  // per method
}

TEST(BenchMemory, HighWaterMarkCoversAnAllocation) {
  // A property of the measurement, not a timing: after touching 64 MiB the high-water
  // mark is at least 64 MiB above the RSS before (when the reset works) or at least
  // 64 MiB in any case.
  bool reset = reset_peak_memory();
  double before = rss_mb();
  {
    std::vector<char> block(64u << 20);
    for (size_t i = 0; i < block.size(); i += 4096) block[i] = char(i);
    volatile char sink = block[block.size() / 2];
    (void)sink;
  }
  double peak = hwm_mb();
  if (reset) {
    EXPECT_GE(peak - before, 63.0);
  }
  EXPECT_GE(peak, 64.0);
}

}  // namespace
}  // namespace visgate::bench
