// Benchmark reports: machine and commit records, CSV/JSON/Markdown tables, gnuplot
// charts, log-log slope fits and RMS errors (see report.h).
#include <algorithm>
#include "tools/bench/report.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "lib/scene/json_exact.h"

extern char** environ;

namespace visgate::bench {

namespace {

std::string read_small_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string trim(const std::string& s) {
  size_t a = s.find_first_not_of(" \t\r\n"), b = s.find_last_not_of(" \t\r\n");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

// Runs a command without a shell; returns its exit status (-1 if it could not start)
// and its standard output. Standard error goes to `err_path` (or is discarded).
int run_program(const std::vector<std::string>& argv, std::string* out, const std::string& err_path = "/dev/null") {
  int pipefd[2];
  if (::pipe(pipefd) != 0) return -1;
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, pipefd[1], 1);
  posix_spawn_file_actions_addclose(&fa, pipefd[0]);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawnp(&pid, args[0], &fa, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  ::close(pipefd[1]);
  if (rc != 0) {
    ::close(pipefd[0]);
    return -1;
  }
  char buf[4096];
  ssize_t n;
  while ((n = ::read(pipefd[0], buf, sizeof buf)) > 0)
    if (out) out->append(buf, size_t(n));
  ::close(pipefd[0]);
  int status = 0;
  if (::waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string format_number(double v, int digits) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  if (v == std::floor(v) && std::fabs(v) < 1e15) {
    char b[32];
    std::snprintf(b, sizeof b, "%.0f", v);
    return b;
  }
  char b[48];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

std::string cell_text(const Json& v, int digits) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number()) return format_number(v.get<double>(), digits);
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_null()) return "";
  return v.dump();
}

std::string csv_escape(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string parse_cpu_model(const std::string& cpuinfo) {
  std::istringstream in(cpuinfo);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    auto colon = line.find(':');
    if (colon != std::string::npos) return trim(line.substr(colon + 1));
  }
  return "unknown";
}

long parse_meminfo_kb(const std::string& meminfo, const std::string& key) {
  std::istringstream in(meminfo);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(key + ":", 0) != 0) continue;
    try {
      return std::stol(line.substr(key.size() + 1));
    } catch (...) {
      return 0;
    }
  }
  return 0;
}

MachineInfo machine_info() {
  MachineInfo m;
  m.cpu_model = parse_cpu_model(read_small_file("/proc/cpuinfo"));
  m.cores = int(std::thread::hardware_concurrency());
  m.memory_gb = double(parse_meminfo_kb(read_small_file("/proc/meminfo"), "MemTotal")) / (1024.0 * 1024.0);
  struct utsname u {};
  if (::uname(&u) == 0) m.kernel = std::string(u.sysname) + " " + u.release;
#if defined(__VERSION__)
  m.compiler = __VERSION__;
#endif
#ifdef NDEBUG
  m.build = "release (NDEBUG)";
#else
  m.build = "debug (assertions on)";
#endif
  return m;
}

std::string git_commit(const std::string& source_dir) {
  std::string head;
  if (run_program({"git", "-C", source_dir, "rev-parse", "HEAD"}, &head) != 0) return "unknown";
  head = trim(head);
  if (head.empty()) return "unknown";
  std::string status;
  if (run_program({"git", "-C", source_dir, "status", "--porcelain", "--untracked-files=no"}, &status) == 0 &&
      !trim(status).empty())
    head += "-dirty";
  return head;
}

std::string table_csv(const Table& t) {
  std::string out;
  for (size_t c = 0; c < t.columns.size(); ++c) {
    if (c) out += ',';
    out += csv_escape(t.columns[c]);
  }
  out += "\n";
  for (const auto& row : t.rows) {
    for (size_t c = 0; c < row.size(); ++c) {
      if (c) out += ',';
      out += csv_escape(cell_text(row[c], 9));
    }
    out += "\n";
  }
  return out;
}

Json table_json(const Table& t) {
  Json j;
  j["caption"] = t.caption;
  j["columns"] = t.columns;
  Json rows = Json::array();
  for (const auto& row : t.rows) {
    Json r = Json::object();
    for (size_t c = 0; c < row.size() && c < t.columns.size(); ++c) r[t.columns[c]] = row[c];
    rows.push_back(std::move(r));
  }
  j["rows"] = std::move(rows);
  return j;
}

std::string table_markdown(const Table& t, int digits) {
  std::string out = "|";
  for (const auto& c : t.columns) {
    out += ' ';
    out += c;
    out += " |";
  }
  out += "\n|";
  for (size_t c = 0; c < t.columns.size(); ++c) out += "---|";
  out += "\n";
  for (const auto& row : t.rows) {
    out += "|";
    for (const auto& v : row) {
      out += ' ';
      out += cell_text(v, digits);
      out += " |";
    }
    out += "\n";
  }
  return out;
}

void add_sorted(Chart& c, Series s) {
  sort_by_x(s);
  c.series.push_back(std::move(s));
}

void sort_by_x(Series& s) {
  std::vector<size_t> idx(std::min(s.x.size(), s.y.size()));
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return s.x[a] < s.x[b]; });
  Series out{s.name, {}, {}, {}};
  for (size_t i : idx) {
    out.x.push_back(s.x[i]);
    out.y.push_back(s.y[i]);
    out.labels.push_back(i < s.labels.size() ? s.labels[i] : std::string());
  }
  s = std::move(out);
}

std::string chart_data(const Chart& c, std::vector<std::string>& names) {
  names.clear();
  std::string out;
  for (const auto& s : c.series) {
    std::string block;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      double x = s.x[i], y = s.y[i];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      if ((c.logx && x <= 0) || (c.logy && y <= 0)) continue;
      block += format_number(x, 9) + " " + format_number(y, 9);
      block += " \"" + (i < s.labels.size() ? s.labels[i] : std::string()) + "\"\n";
    }
    if (block.empty()) continue;
    if (!names.empty()) out += "\n\n";
    out += "# " + s.name + "\n" + block;
    names.push_back(s.name);
  }
  return out;
}

Result<WriteOutcome> write_report(const Report& r, const std::string& dir, const std::string& scripts,
                                  const MachineInfo& machine, const std::string& commit) {
  namespace fs = std::filesystem;
  WriteOutcome outcome;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Error{dir + ": cannot create the output directory: " + ec.message()};

  auto write = [&](const std::string& name, const std::string& text) -> Status {
    std::string path = (fs::path(dir) / name).string();
    Status st = write_file_atomic(path, text);
    if (st) outcome.files.push_back(path);
    return st;
  };

  Json doc;
  doc["format"] = "visgate-bench";
  doc["version"] = 1;
  doc["experiment"] = r.experiment;
  doc["machine"] = {{"cpu_model", machine.cpu_model}, {"cores", machine.cores}, {"memory_gb", machine.memory_gb},
                    {"kernel", machine.kernel}, {"compiler", machine.compiler}, {"build", machine.build}};
  doc["commit"] = commit;
  doc["options"] = r.options;
  doc["notes"] = r.notes;
  Json tables = Json::object();
  for (const auto& t : r.tables) {
    tables[t.name] = table_json(t);
    Status st = write(r.experiment + "-" + t.name + ".csv", table_csv(t));
    if (!st) return st.error();
  }
  doc["tables"] = std::move(tables);

  Json charts = Json::array();
  for (const auto& c : r.charts) {
    std::vector<std::string> names;
    std::string data = chart_data(c, names);
    Status st = write(c.name + ".dat", data);
    if (!st) return st.error();
    Json cj = {{"name", c.name}, {"title", c.title}, {"xlabel", c.xlabel}, {"ylabel", c.ylabel},
               {"logx", c.logx}, {"logy", c.logy}, {"series", names}};
    if (names.empty()) {
      outcome.chart_errors.push_back(c.name + ": no data points");
      cj["error"] = "no data points";
      charts.push_back(cj);
      continue;
    }
    std::string joined;
    for (const auto& n : names) joined += (joined.empty() ? "" : " ") + n;
    auto quote = [](std::string s) {
      for (auto& ch : s)
        if (ch == '\'') ch = '`';
      return "'" + s + "'";
    };
    std::string base = (fs::path(dir) / c.name).string();
    std::string expr = "dat=" + quote(base + ".dat") + "; out=" + quote(base) + "; ttl=" + quote(c.title) +
                       "; xl=" + quote(c.xlabel) + "; yl=" + quote(c.ylabel) + "; names=" + quote(joined) +
                       "; logx=" + std::to_string(int(c.logx)) + "; logy=" + std::to_string(int(c.logy));
    std::string script = (fs::path(scripts) / "lines.gp").string();
    cj["command"] = "gnuplot -e \"" + expr + "\" " + script;
    int rc = run_program({"gnuplot", "-e", expr, script}, nullptr, base + ".gnuplot.log");
    if (rc == 0) {
      outcome.files.push_back(base + ".png");
      outcome.files.push_back(base + ".svg");
      cj["png"] = c.name + ".png";
      cj["svg"] = c.name + ".svg";
      fs::remove(base + ".gnuplot.log", ec);  // only warnings when it succeeded
    } else {
      std::string why = rc < 0 ? "gnuplot not found" : "gnuplot exit " + std::to_string(rc) + " (see " + base + ".gnuplot.log)";
      outcome.chart_errors.push_back(c.name + ": " + why);
      cj["error"] = why;
    }
    charts.push_back(std::move(cj));
  }
  doc["charts"] = std::move(charts);
  Status st = write(r.experiment + ".json", doc.dump(2) + "\n");
  if (!st) return st.error();
  return outcome;
}

SlopeFit fit_loglog(const std::vector<double>& x, const std::vector<double>& y) {
  SlopeFit f;
  std::vector<double> lx, ly;
  for (size_t i = 0; i < x.size() && i < y.size(); ++i)
    if (x[i] > 0 && y[i] > 0 && std::isfinite(x[i]) && std::isfinite(y[i])) {
      lx.push_back(std::log(x[i]));
      ly.push_back(std::log(y[i]));
    }
  f.points = lx.size();
  if (lx.size() < 2) return f;
  double mx = 0, my = 0;
  for (size_t i = 0; i < lx.size(); ++i) mx += lx[i], my += ly[i];
  mx /= double(lx.size());
  my /= double(lx.size());
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < lx.size(); ++i) {
    sxx += (lx[i] - mx) * (lx[i] - mx);
    sxy += (lx[i] - mx) * (ly[i] - my);
    syy += (ly[i] - my) * (ly[i] - my);
  }
  if (sxx == 0) return f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  f.r2 = syy == 0 ? 1.0 : (sxy * sxy) / (sxx * syy);
  return f;
}

double rms_error(const std::vector<double>& a, const std::vector<double>& b) {
  VG_CHECK(a.size() == b.size());
  if (a.empty()) return 0.0;
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / double(a.size()));
}

}  // namespace visgate::bench
