// Tests of the pieces of `visgate bench` and `visgate render` that stand alone: the CSV,
// JSON and Markdown writers, chart data, machine-info parsers, log-log slope fitting and
// RMS error against hand-computed cases, the sweep budget, receiver-grid images and the
// PNG writer (round trip through stb_image). No timing is asserted anywhere.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "tools/bench/image.h"
#include "tools/bench/measure.h"
#include "tools/bench/report.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wcast-align"
#pragma GCC diagnostic ignored "-Wshadow"
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <stb_image.h>
#pragma GCC diagnostic pop

namespace visgate::bench {
namespace {

Table sample_table() {
  Table t{"points", "a caption", {"method", "n", "seconds", "note"}, {}};
  t.add_row({"embree", 64, 0.125, "plain"});
  t.add_row({"brute", 1024, 1.0 / 3.0, "has, comma and \"quote\""});
  return t;
}

TEST(BenchCsv, HeaderRowsNumbersAndQuoting) {
  // Integers exactly, other numbers with 9 significant digits, RFC 4180 quoting.
  EXPECT_EQ(table_csv(sample_table()),
            "method,n,seconds,note\n"
            "embree,64,0.125,plain\n"
            "brute,1024,0.333333333,\"has, comma and \"\"quote\"\"\"\n");
}

TEST(BenchCsv, NaNIsWrittenAsText) {
  Table t{"x", "", {"v"}, {}};
  t.add_row({std::nan("")});
  EXPECT_EQ(table_csv(t), "v\nnan\n");
}

TEST(BenchJson, RowsAreObjectsKeyedByColumn) {
  Json j = table_json(sample_table());
  EXPECT_EQ(j["caption"], "a caption");
  ASSERT_EQ(j["rows"].size(), 2u);
  EXPECT_EQ(j["rows"][0]["method"], "embree");
  EXPECT_EQ(j["rows"][0]["n"], 64);
  EXPECT_DOUBLE_EQ(j["rows"][1]["seconds"].get<double>(), 1.0 / 3.0);
  EXPECT_EQ(j["columns"][3], "note");
}

TEST(BenchMarkdown, OneLinePerRowWithHeaderRule) {
  Table t{"x", "", {"a", "b"}, {}};
  t.add_row({"m", 0.5});
  EXPECT_EQ(table_markdown(t), "| a | b |\n|---|---|\n| m | 0.5 |\n");
}

TEST(BenchChart, LogAxesDropNonPositivePointsAndEmptySeries) {
  Chart c{"c", "t", "x (s)", "y", true, true, {}};
  c.series.push_back({"a", {1, 0, 10}, {2, 5, 20}, {"N=4", "", ""}});
  c.series.push_back({"empty", {1}, {0}, {}});  // y = 0 on a log axis: nothing left
  c.series.push_back({"b", {2}, {3}, {}});
  std::vector<std::string> names;
  std::string d = chart_data(c, names);
  ASSERT_EQ(names, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(d, "# a\n1 2 \"N=4\"\n10 20 \"\"\n\n\n# b\n2 3 \"\"\n");
}

TEST(BenchChart, LinearAxesKeepZeros) {
  Chart c{"c", "t", "x", "y", false, false, {}};
  c.series.push_back({"a", {0}, {0}, {}});
  std::vector<std::string> names;
  EXPECT_EQ(chart_data(c, names), "# a\n0 0 \"\"\n");
}

TEST(BenchMachine, ParsesCpuModelAndMemTotal) {
  std::string cpuinfo = "processor\t: 0\nvendor_id\t: X\nmodel name\t: Test CPU @ 3.0GHz  \nflags\t: a b\n"
                        "processor\t: 1\nmodel name\t: Other\n";
  EXPECT_EQ(parse_cpu_model(cpuinfo), "Test CPU @ 3.0GHz");
  EXPECT_EQ(parse_cpu_model("processor : 0\n"), "unknown");
  std::string meminfo = "MemTotal:       24683620 kB\nMemFree:  100 kB\n";
  EXPECT_EQ(parse_meminfo_kb(meminfo, "MemTotal"), 24683620);
  EXPECT_EQ(parse_meminfo_kb(meminfo, "MemFree"), 100);
  EXPECT_EQ(parse_meminfo_kb(meminfo, "SwapTotal"), 0);
}

TEST(BenchMachine, ThisMachineHasCoresAndMemory) {
  MachineInfo m = machine_info();
  EXPECT_GE(m.cores, 1);
  EXPECT_GT(m.memory_gb, 0.0);
  EXPECT_FALSE(m.cpu_model.empty());
}

TEST(BenchFit, HandComputedLogLogSlope) {
  // Points (1,1), (2,4), (4,8): in base-2 logs x' = 0,1,2 and y' = 0,2,3, so
  // Sxx = 2, Sxy = (-1)(-5/3) + (1)(4/3) = 3, slope 3/2 (the base cancels);
  // intercept (natural log) = mean ln y - 1.5 mean ln x = (5/3 - 3/2) ln 2 = ln 2 / 6;
  // Syy = 25/9 + 1/9 + 16/9 = 14/3, r^2 = Sxy^2 / (Sxx Syy) = 9 / (28/3) = 27/28.
  SlopeFit f = fit_loglog({1, 2, 4}, {1, 4, 8});
  EXPECT_EQ(f.points, 3u);
  EXPECT_NEAR(f.slope, 1.5, 1e-12);
  EXPECT_NEAR(f.intercept, std::log(2.0) / 6.0, 1e-12);
  EXPECT_NEAR(f.r2, 27.0 / 28.0, 1e-12);
}

TEST(BenchFit, ExactPowerLawAndIgnoredPoints) {
  // y = 3 x^2: slope 2, intercept ln 3, r^2 1; the point with x = 0 and the one with
  // y < 0 are not on log axes and are ignored.
  SlopeFit f = fit_loglog({0, 1, 10, 100, 5}, {7, 3, 300, 30000, -1});
  EXPECT_EQ(f.points, 3u);
  EXPECT_NEAR(f.slope, 2.0, 1e-12);
  EXPECT_NEAR(f.intercept, std::log(3.0), 1e-12);
  EXPECT_NEAR(f.r2, 1.0, 1e-12);
  EXPECT_EQ(fit_loglog({1}, {1}).points, 1u);
  EXPECT_EQ(fit_loglog({1}, {1}).slope, 0.0);
}

TEST(BenchRms, HandComputed) {
  // Differences 0, 2, 0: sqrt(4 / 3).
  EXPECT_NEAR(rms_error({1, 2, 3}, {1, 0, 3}), std::sqrt(4.0 / 3.0), 1e-15);
  EXPECT_EQ(rms_error({}, {}), 0.0);
  EXPECT_EQ(rms_error({0.25, 0.5}, {0.25, 0.5}), 0.0);
}

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

TEST(BenchImage, GridOrientationAndScale) {
  // Receiver (a, b) has index b*nu + a and is drawn at column a, row nv-1-b.
  ReceiverGrid g;
  g.nu = 2;
  g.nv = 2;
  std::vector<Rgb> c = {{1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}};
  Image img = grid_image(g, c, 2);
  ASSERT_EQ(img.width, 4);
  ASSERT_EQ(img.height, 4);
  EXPECT_EQ(img.at(0, 0).r, 3);  // top-left: a = 0, b = 1
  EXPECT_EQ(img.at(3, 0).r, 4);
  EXPECT_EQ(img.at(1, 3).r, 1);  // bottom-left: a = 0, b = 0
  EXPECT_EQ(img.at(2, 2).r, 2);
  EXPECT_EQ(auto_scale(g, 512), 256);
}

TEST(BenchImage, GrayClampsAndRounds) {
  EXPECT_EQ(gray(0.5).g, 128);  // round(127.5)
  EXPECT_EQ(gray(-1).r, 0);
  EXPECT_EQ(gray(2).b, 255);
  EXPECT_EQ(gray(std::nan("")).r, 0);
}

TEST(BenchPng, RoundTripThroughStbImage) {
  Image img;
  img.width = 3;
  img.height = 2;
  for (int i = 0; i < 6; ++i)
    for (int k = 0; k < 3; ++k) img.rgb.push_back(uint8_t(i * 40 + k * 7 + 1));
  std::string path = (std::filesystem::temp_directory_path() / ("vg_bench_test_" + std::to_string(::getpid()) + ".png")).string();
  ASSERT_TRUE(write_png(path, img).ok());
  int w = 0, h = 0, n = 0;
  unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 3);
  ASSERT_NE(data, nullptr);
  EXPECT_EQ(w, 3);
  EXPECT_EQ(h, 2);
  EXPECT_EQ(std::vector<uint8_t>(data, data + 18), img.rgb);
  stbi_image_free(data);
  std::filesystem::remove(path);
}

TEST(BenchPng, BadPathAndEmptyImageAreErrorsNamingTheFile) {
  Image img{1, 1, {1, 2, 3}};
  Status st = write_png("/nonexistent-dir/x.png", img);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("/nonexistent-dir/x.png"), std::string::npos);
  EXPECT_FALSE(write_png("/tmp/never.png", Image{}).ok());
}

// A scene of two lights with 2 and 1 samples (3 relations per receiver) and 2 receivers;
// only the counts matter to the fraction and diff helpers.
Scene two_light_scene() {
  Scene s;
  s.lights.resize(2);
  s.lights[0].samples = 2;
  s.lights[1].samples = 1;
  s.receivers.resize(2);
  return s;
}

TEST(BenchRender, ClassFractionCountsDegenerateAsHalf) {
  Scene s = two_light_scene();
  // Receiver 0: light 0 "vd" -> 0.75, light 1 "b" -> 0: mean 0.375.
  // Receiver 1: light 0 "vv" -> 1, light 1 "v" -> 1: mean 1.
  auto f = mean_class_fraction(s, {"vdb", "vvv"});
  ASSERT_EQ(f.size(), 2u);
  EXPECT_DOUBLE_EQ(f[0], 0.375);
  EXPECT_DOUBLE_EQ(f[1], 1.0);
}

TEST(BenchRender, MethodFractionIsTheMeanOverLights) {
  Scene s = two_light_scene();
  SolveResult r = make_empty_result(s);
  r.receivers[0].visible_fraction = {0.5f, 1.0f};
  r.receivers[1].visible_fraction = {0.0f, 0.25f};
  auto f = mean_visible_fraction(s, r);
  EXPECT_DOUBLE_EQ(f[0], 0.75);
  EXPECT_DOUBLE_EQ(f[1], 0.125);
}

TEST(BenchRender, DiffSplitsByTauAndSkipsDegenerate) {
  Scene s = two_light_scene();
  SolveResult r = make_empty_result(s);
  // Receiver 0 answers visible, visible, blocked; receiver 1 blocked everywhere.
  r.receivers[0].set_visible(0, true);
  r.receivers[0].set_visible(1, true);
  std::vector<std::string> classes = {"bdb", "vbv"};
  std::vector<std::vector<double>> margins = {{1e-3, 0.0, 0.5}, {1e-7, 0.2, 1e-5}};
  auto d = diff_receivers(s, r, classes, margins, 1e-5);
  // Receiver 0: relation 0 disagrees with margin 1e-3 >= tau (mismatch); relation 1 is
  // degenerate (ignored); relation 2 agrees.
  EXPECT_EQ(d[0].mismatches, 1u);
  EXPECT_EQ(d[0].below_tau, 0u);
  // Receiver 1: relation 0 disagrees below tau, relation 1 agrees, relation 2 disagrees
  // with margin exactly tau: a mismatch (margin >= tau).
  EXPECT_EQ(d[1].mismatches, 1u);
  EXPECT_EQ(d[1].below_tau, 1u);

  auto c = diff_colors({{0, 0}, {0, 2}, {3, 0}}, {1.0, 0.5, 0.5}, 3);
  EXPECT_EQ(c[0].r, gray(0.4).r);  // agreement: dim gray of the exact fraction
  EXPECT_EQ(c[1].b, kBelowTauColor.b);
  EXPECT_EQ(c[1].r, kBelowTauColor.r);
  EXPECT_EQ(c[2].r, kMismatchColor.r);  // every relation mismatches: full brightness
  EXPECT_EQ(c[2].g, kMismatchColor.g);
}

}  // namespace
}  // namespace visgate::bench
