// Benchmark reports (DESIGN section 10): every figure of a `visgate bench` run next to
// the machine, the commit and every option that produced it. A report holds named
// tables (written as CSV, one file per table, and all together as JSON), notes (methods
// or families skipped and why) and charts drawn by the gnuplot scripts in tools/bench.
// Also the small statistics the experiments share: least-squares slopes on log-log
// axes and RMS errors.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lib/base/result.h"

namespace visgate::bench {

using Json = nlohmann::ordered_json;

// The machine a benchmark ran on: CPU model (first "model name" of /proc/cpuinfo),
// hardware threads, total memory (MemTotal of /proc/meminfo), kernel and compiler.
struct MachineInfo {
  std::string cpu_model;
  int cores = 0;
  double memory_gb = 0.0;
  std::string kernel, compiler, build;
};
MachineInfo machine_info();
// Parsers behind machine_info, exposed for tests: the first "model name" value of a
// /proc/cpuinfo text, and MemTotal (kB) of a /proc/meminfo text (0 when absent).
std::string parse_cpu_model(const std::string& cpuinfo);
long parse_meminfo_kb(const std::string& meminfo, const std::string& key);

// `git rev-parse HEAD` of the source tree, with "-dirty" appended when `git status
// --porcelain` lists changes; "unknown" without git.
std::string git_commit(const std::string& source_dir);

// A table: column names and rows of cells (numbers or strings).
struct Table {
  std::string name;      // file stem: <experiment>-<name>.csv
  std::string caption;   // one line saying what the table is
  std::vector<std::string> columns;
  std::vector<std::vector<Json>> rows;

  void add_row(std::vector<Json> row) { rows.push_back(std::move(row)); }
};
// RFC 4180 CSV: a header line, then one line per row; numbers with 9 significant digits
// (integers exactly), strings quoted when they hold a comma, quote or line break.
std::string table_csv(const Table& t);
// {"caption", "columns", "rows": [{column: value, ...}, ...]}
Json table_json(const Table& t);
// A Markdown table (for README "Results"), numbers with `digits` significant digits.
std::string table_markdown(const Table& t, int digits = 4);

// One chart: series of (x, y) points, one legend entry per series, drawn by
// tools/bench/lines.gp as PNG and SVG.
struct Series {
  std::string name;  // legend entry (a method name); no spaces
  std::vector<double> x, y;
  std::vector<std::string> labels;  // optional point labels (e.g. "N=64")
};
// Orders a series' points (and labels) by x, for charts whose points come in another
// order (configurations, families) and are drawn as one line.
void sort_by_x(Series& s);

struct Chart {
  std::string name;  // file stem
  std::string title, xlabel, ylabel;  // labels carry units, e.g. "time (s)"
  bool logx = false, logy = false;
  std::vector<Series> series;
};
// Adds `s` to `c` with its points ordered by x (sort_by_x).
void add_sorted(Chart& c, Series s);
// The gnuplot data file of a chart: one block per series (blocks separated by two blank
// lines, so `index i` selects series i), points with non-positive coordinates on a log
// axis dropped. Series left empty are omitted; `names` receives the kept names in order.
std::string chart_data(const Chart& c, std::vector<std::string>& names);

struct Report {
  std::string experiment;
  Json options = Json::object();  // every option of the run
  std::vector<Table> tables;
  std::vector<Chart> charts;
  std::vector<std::string> notes;  // skipped methods/families, measurement caveats
};

struct WriteOutcome {
  std::vector<std::string> files;  // every file written
  std::vector<std::string> chart_errors;  // charts gnuplot could not draw
};
// Writes DIR/<experiment>.json (machine, commit, options, tables, notes, charts),
// DIR/<experiment>-<table>.csv per table, and per chart DIR/<chart>.dat plus
// DIR/<chart>.png and DIR/<chart>.svg through gnuplot (script directory `scripts`).
// Creates DIR. Errors name the file that could not be written.
Result<WriteOutcome> write_report(const Report& r, const std::string& dir, const std::string& scripts,
                                  const MachineInfo& machine, const std::string& commit);

// Least-squares fit of log(y) = slope * log(x) + c over the points with x, y > 0.
struct SlopeFit {
  double slope = 0.0, intercept = 0.0, r2 = 0.0;
  size_t points = 0;
};
SlopeFit fit_loglog(const std::vector<double>& x, const std::vector<double>& y);

// sqrt(mean((a_i - b_i)^2)); 0 for empty input. Sizes must match (VG_CHECK).
double rms_error(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace visgate::bench
