// `exec:CMD` methods (see exec_method.h).
#include "lib/external/exec_method.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "lib/scene/scene_json.h"

extern char** environ;

namespace visgate::external {

namespace {

std::string read_file_text(const std::string& path, bool& ok) {
  std::ifstream in(path, std::ios::binary);
  ok = bool(in);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The last line-ish part of a captured stream, on one line, for a failure message.
std::string tail_of(const std::string& path) {
  bool ok = false;
  std::string s = read_file_text(path, ok);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  if (s.size() > 300) s = "..." + s.substr(s.size() - 300);
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

// A private temporary folder, removed with everything in it.
struct TempDir {
  std::string path;
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string tmpl = std::string(base && *base ? base : "/tmp") + "/visgate-exec-XXXXXX";
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    if (::mkdtemp(buf.data())) path = buf.data();
  }
  ~TempDir() {
    std::error_code ec;
    if (!path.empty()) std::filesystem::remove_all(path, ec);
  }
};

std::string signal_name(int sig) {
  const char* d = ::strsignal(sig);
  return "signal " + std::to_string(sig) + (d ? std::string(" (") + d + ")" : "");
}

}  // namespace

std::string write_explicit_scene_json(const Scene& scene) {
  SceneWriteOptions opt;
  opt.relation_points = true;
  return write_scene_json(scene, opt);
}

Result<SolveResult> read_result_json(const std::string& text, const Scene& scene, const std::string& origin) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    return Error{origin + ": JSON parse error: " + e.what()};
  }
  if (!doc.is_object() || !doc.contains("format") || doc["format"] != "visgate-result")
    return Error{origin + ": format: expected \"visgate-result\""};
  if (!doc.contains("version") || doc["version"] != 1) return Error{origin + ": version: expected 1"};
  if (!doc.contains("receivers") || !doc["receivers"].is_array())
    return Error{origin + ": receivers: expected an array"};
  const auto& recs = doc["receivers"];
  if (recs.size() != scene.receivers.size())
    return Error{origin + ": receivers: has " + std::to_string(recs.size()) + " entries, the scene has " +
                 std::to_string(scene.receivers.size()) + " receivers"};
  SolveResult r = make_empty_result(scene);
  const size_t bits = scene.samples_per_receiver();
  bool fractions_given = true;
  for (size_t i = 0; i < recs.size(); ++i) {
    const std::string where = origin + ": receivers[" + std::to_string(i) + "]";
    if (!recs[i].is_object() || !recs[i].contains("visible") || !recs[i]["visible"].is_string())
      return Error{where + ".visible: expected a string of '0' and '1'"};
    const std::string& vis = recs[i]["visible"].get_ref<const std::string&>();
    if (vis.size() != bits)
      return Error{where + ".visible: has " + std::to_string(vis.size()) + " characters, expected " +
                   std::to_string(bits) + " (one per relation)"};
    for (size_t b = 0; b < bits; ++b) {
      if (vis[b] != '0' && vis[b] != '1')
        return Error{where + ".visible[" + std::to_string(b) + "]: expected '0' or '1'"};
      if (vis[b] == '1') r.receivers[i].set_visible(b, true);
    }
    if (recs[i].contains("visible_fraction")) {
      const auto& fr = recs[i]["visible_fraction"];
      if (!fr.is_array() || fr.size() != scene.lights.size())
        return Error{where + ".visible_fraction: expected one number per light (" +
                     std::to_string(scene.lights.size()) + ")"};
      for (size_t l = 0; l < fr.size(); ++l) {
        if (!fr[l].is_number() || !(fr[l].get<double>() >= 0.0 && fr[l].get<double>() <= 1.0))
          return Error{where + ".visible_fraction[" + std::to_string(l) + "]: expected a number in [0, 1]"};
        r.receivers[i].visible_fraction[l] = float(fr[l].get<double>());
      }
    } else {
      fractions_given = false;
    }
  }
  if (!fractions_given) {
    // Fractions from the bits for every receiver, keeping the ones given.
    SolveResult from_bits = r;
    fractions_from_bits(scene, from_bits);
    for (size_t i = 0; i < recs.size(); ++i)
      if (!recs[i].contains("visible_fraction")) r.receivers[i].visible_fraction = from_bits.receivers[i].visible_fraction;
  }
  if (doc.contains("seconds") && doc["seconds"].is_number()) r.stats.set("reported_seconds", doc["seconds"].get<double>());
  if (doc.contains("stats") && doc["stats"].is_object())
    for (const auto& [k, v] : doc["stats"].items())
      if (v.is_number()) r.stats.set(k, v.get<double>());
  return r;
}

std::vector<OptionSpec> ExecSolver::options() const {
  return {{"timeout", "Seconds before the program is killed and the method fails (default 60)", {}}};
}

SolveResult ExecSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string who = name();
  const long timeout = opt.get_int("timeout", kDefaultExecTimeoutSeconds);
  auto fail = [&](const std::string& why) -> ExternalMethodError {
    return ExternalMethodError(who + ": " + why + " (scene " + scene.name + ")");
  };

  TempDir dir;
  if (dir.path.empty()) throw fail(std::string("cannot create a temporary folder: ") + std::strerror(errno));
  const std::string scene_path = dir.path + "/scene.json", result_path = dir.path + "/result.json";
  const std::string out_path = dir.path + "/stdout.txt", err_path = dir.path + "/stderr.txt";
  {
    std::ofstream f(scene_path, std::ios::binary);
    f << write_explicit_scene_json(scene);
    if (!f.flush()) throw fail("cannot write " + scene_path);
  }

  // Spawn `sh -c 'CMD "$@"' sh SCENE RESULT` in a process group of its own, stdin from
  // /dev/null, stdout and stderr to files (visgate's own stdout may carry JSON).
  posix_spawn_file_actions_t fa;
  posix_spawnattr_t at;
  posix_spawn_file_actions_init(&fa);
  posix_spawnattr_init(&at);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&at, &none);
  posix_spawnattr_setsigdefault(&at, &all);
  posix_spawnattr_setpgroup(&at, 0);
  posix_spawnattr_setflags(&at, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  const std::string script = command_ + " \"$@\"";
  const char* argv[] = {"sh", "-c", script.c_str(), "sh", scene_path.c_str(), result_path.c_str(), nullptr};
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, "/bin/sh", &fa, &at, const_cast<char* const*>(argv), environ);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&at);
  if (rc != 0) throw fail(std::string("cannot start /bin/sh: ") + std::strerror(rc));

  // Wait, polling: 1 ms steps at first (most test programs end within milliseconds),
  // then up to 20 ms.
  int status = 0;
  const auto deadline = t0 + std::chrono::seconds(timeout);
  auto step = std::chrono::microseconds(200);
  for (;;) {
    const pid_t w = ::waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) throw fail(std::string("waitpid: ") + std::strerror(errno));
    if (std::chrono::steady_clock::now() >= deadline) {
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      throw fail("timed out after " + std::to_string(timeout) + " s (killed; --opt timeout=SECONDS)");
    }
    std::this_thread::sleep_for(step);
    step = std::min(step * 2, std::chrono::microseconds(20000));
  }
  // The program's children, if it left any behind.
  ::kill(-pid, SIGKILL);

  if (WIFSIGNALED(status)) {
    std::string e = tail_of(err_path);
    throw fail("crashed: " + signal_name(WTERMSIG(status)) + (e.empty() ? "" : "; stderr: " + e));
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0) {
    std::string e = tail_of(err_path);
    // sh reports a signal of the program it ran as 128 + N.
    std::string what = WEXITSTATUS(status) > 128 && WEXITSTATUS(status) < 160
                           ? "crashed: " + signal_name(WEXITSTATUS(status) - 128)
                           : "exit status " + std::to_string(WEXITSTATUS(status));
    throw fail(what + (e.empty() ? "" : "; stderr: " + e));
  }
  bool ok = false;
  const std::string text = read_file_text(result_path, ok);
  if (!ok) throw fail("wrote no result file");
  auto r = read_result_json(text, scene, "result");
  if (!r) throw fail("malformed result: " + r.error().message);
  r->stats.set("exec_seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  r->seconds = r->stats.get("exec_seconds");
  return std::move(*r);
}

}  // namespace visgate::external
