// tools/bench/report: the CSV, JSON and Markdown writers, chart data, machine-info
// parsers, log-log slope fitting and RMS error against hand-computed cases.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "tools/bench/report.h"

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

}  // namespace
}  // namespace visgate::bench
