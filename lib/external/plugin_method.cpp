// `plugin:PATH` methods (see plugin_method.h).
#include "lib/external/plugin_method.h"

#include <dlfcn.h>
#include <setjmp.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>

namespace visgate::external {

struct LoadedPlugin {
  void* handle = nullptr;
  const visgate_method_v1_t* desc = nullptr;
  std::atomic<bool> crashed{false};
  std::string crash_reason;  // set once, before `crashed`
};

namespace {

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

// Libraries stay loaded for the life of the process: a plugin's code may still be on a
// stack (a guarded crash) or referenced by a solver another thread holds.
LoadedPlugin* load_plugin(const std::string& path) {
  static std::map<std::string, std::unique_ptr<LoadedPlugin>> loaded;
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto it = loaded.find(path);
  if (it != loaded.end()) return it->second.get();
  const std::string who = "plugin:" + path;
  ::dlerror();
  void* h = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!h) {
    const char* e = ::dlerror();
    throw ExternalMethodError(who + ": cannot load: " + (e ? e : "unknown dlopen error"));
  }
  auto fn = reinterpret_cast<visgate_method_v1_fn>(::dlsym(h, VISGATE_METHOD_V1_SYMBOL));
  if (!fn) throw ExternalMethodError(who + ": the library exports no " VISGATE_METHOD_V1_SYMBOL " (include/visgate/plugin.h)");
  const visgate_method_v1_t* d = fn();
  if (!d) throw ExternalMethodError(who + ": " VISGATE_METHOD_V1_SYMBOL "() returned NULL");
  if (d->abi_version != VISGATE_METHOD_ABI_VERSION)
    throw ExternalMethodError(who + ": ABI version " + std::to_string(d->abi_version) + ", this visgate speaks " +
                              std::to_string(VISGATE_METHOD_ABI_VERSION));
  if (!d->solve) throw ExternalMethodError(who + ": the descriptor has no solve function");
  auto p = std::make_unique<LoadedPlugin>();
  p->handle = h;
  p->desc = d;
  return loaded.emplace(path, std::move(p)).first->second.get();
}

// ---- the crash guard -----------------------------------------------------------------

constexpr int kGuardedSignals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP};
constexpr size_t kSignalCount = sizeof(kGuardedSignals) / sizeof(kGuardedSignals[0]);

thread_local sigjmp_buf* t_jump = nullptr;
struct sigaction g_previous[kSignalCount];
int g_guard_depth = 0;  // guarded solves running (under g_guard_mutex)
std::mutex g_guard_mutex;

void guard_handler(int sig) {
  if (t_jump) siglongjmp(*t_jump, sig);
  // Not a guarded thread: restore the handler visgate found and let the signal take its
  // course (a fault re-executes the instruction; abort() re-raises).
  for (size_t k = 0; k < kSignalCount; ++k)
    if (kGuardedSignals[k] == sig) sigaction(sig, &g_previous[k], nullptr);
}

// An alternate stack per thread, so that a stack overflow in the plugin is caught too.
void ensure_alt_stack() {
  thread_local std::unique_ptr<char[]> stack;
  if (stack) return;
  const size_t size = 1 << 16;
  stack.reset(new char[size]);
  stack_t ss{};
  ss.ss_sp = stack.get();
  ss.ss_size = size;
  ss.ss_flags = 0;
  sigaltstack(&ss, nullptr);
}

struct GuardScope {
  GuardScope() {
    ensure_alt_stack();
    std::lock_guard<std::mutex> lock(g_guard_mutex);
    if (g_guard_depth++ == 0) {
      struct sigaction sa {};
      sa.sa_handler = guard_handler;
      sigemptyset(&sa.sa_mask);
      sa.sa_flags = SA_ONSTACK | SA_NODEFER;
      for (size_t k = 0; k < kSignalCount; ++k) sigaction(kGuardedSignals[k], &sa, &g_previous[k]);
    }
  }
  ~GuardScope() {
    std::lock_guard<std::mutex> lock(g_guard_mutex);
    if (--g_guard_depth == 0)
      for (size_t k = 0; k < kSignalCount; ++k) sigaction(kGuardedSignals[k], &g_previous[k], nullptr);
  }
};

// Calls the plugin's solve; returns the signal that interrupted it, or 0 (rc set).
// No C++ object with a destructor lives in this frame across the jump.
int guarded_solve(const visgate_method_v1_t* d, void* state, const visgate_scene_v1_t* scene,
                  const visgate_option_v1_t* opts, size_t nopts, uint64_t seed, int threads, visgate_output_v1_t* out,
                  int* rc) {
  sigjmp_buf jump;
  const int sig = sigsetjmp(jump, 1);
  if (sig != 0) {
    t_jump = nullptr;
    return sig;
  }
  t_jump = &jump;
  *rc = d->solve(state, scene, opts, nopts, seed, threads, out);
  t_jump = nullptr;
  return 0;
}

std::string signal_text(int sig) {
  const char* d = ::strsignal(sig);
  return "signal " + std::to_string(sig) + (d ? std::string(" (") + d + ")" : "");
}

}  // namespace

void flatten_scene(const Scene& scene, bool relation_points, FlatScene& f) {
  auto push = [](std::vector<float>& v, const Vec3f& p) {
    v.push_back(p.x);
    v.push_back(p.y);
    v.push_back(p.z);
  };
  f = FlatScene{};
  f.vertices.reserve(scene.mesh.vertices.size() * 3);
  for (const auto& v : scene.mesh.vertices) push(f.vertices, v);
  f.triangles.reserve(scene.mesh.triangles.size() * 3);
  for (const auto& t : scene.mesh.triangles) f.triangles.insert(f.triangles.end(), t.begin(), t.end());
  for (const auto& r : scene.receivers) {
    push(f.receiver_points, r.p);
    push(f.receiver_normals, r.n);
  }
  f.light_polygon_offsets.push_back(0);
  f.light_offsets.push_back(0);
  for (const auto& L : scene.lights) {
    for (const auto& p : L.polygon) push(f.light_polygons, p);
    f.light_polygon_offsets.push_back(f.light_polygon_offsets.back() + L.polygon.size());
    f.light_offsets.push_back(f.light_offsets.back() + uint64_t(L.samples));
    f.light_jitter.push_back(uint32_t(L.jitter));
    f.light_seed.push_back(L.seed);
    f.light_pattern.push_back(L.pattern == SamplePattern::Random     ? VISGATE_PATTERN_RANDOM
                              : L.pattern == SamplePattern::Grid     ? VISGATE_PATTERN_GRID
                              : L.pattern == SamplePattern::Explicit ? VISGATE_PATTERN_EXPLICIT
                                                                     : VISGATE_PATTERN_STRATIFIED);
    for (const auto& p : L.jitter_points) push(f.jitter_points, p);
  }
  const size_t per = scene.samples_per_receiver();
  if (relation_points) {
    f.relation_points.resize(scene.receivers.size() * per * 3);
    float* out = f.relation_points.data();
    for (size_t i = 0; i < scene.receivers.size(); ++i)
      for (const auto& L : scene.lights)
        for (int j = 0; j < L.samples; ++j) {
          const Vec3f& p = sample_position(L, j, i);
          *out++ = p.x;
          *out++ = p.y;
          *out++ = p.z;
        }
  }
  visgate_scene_v1_t& v = f.view;
  v.struct_size = sizeof(visgate_scene_v1_t);
  v.name = scene.name.c_str();
  v.vertices = f.vertices.data();
  v.vertex_count = scene.mesh.vertices.size();
  v.triangles = f.triangles.data();
  v.triangle_count = scene.mesh.triangles.size();
  v.receiver_points = f.receiver_points.data();
  v.receiver_normals = f.receiver_normals.data();
  v.receiver_count = scene.receivers.size();
  v.light_count = scene.lights.size();
  v.light_polygon_offsets = f.light_polygon_offsets.data();
  v.light_polygons = f.light_polygons.data();
  v.light_offsets = f.light_offsets.data();
  v.light_jitter = f.light_jitter.data();
  v.light_seed = f.light_seed.data();
  v.light_pattern = f.light_pattern.data();
  v.jitter_points = f.jitter_points.data();
  v.relations_per_receiver = per;
  v.relation_points = relation_points ? f.relation_points.data() : nullptr;
}

PluginSolver::PluginSolver(std::string path, bool guard) : path_(std::move(path)), guard_(guard) {
  lib_ = load_plugin(path_);
}

PluginSolver::~PluginSolver() {
  if (has_state_ && lib_->desc->free_state && !lib_->crashed.load()) lib_->desc->free_state(state_);
}

std::vector<OptionSpec> PluginSolver::options() const {
  std::vector<OptionSpec> out;
  const visgate_method_v1_t* d = lib_->desc;
  for (size_t k = 0; k < d->option_count && d->options; ++k) {
    const visgate_option_spec_v1_t& s = d->options[k];
    OptionSpec o{s.name ? s.name : "", s.help ? s.help : "", {}};
    if (s.values) {
      std::string all = s.values;
      size_t b = 0;
      for (size_t e; (e = all.find('|', b)) != std::string::npos; b = e + 1) o.values.push_back(all.substr(b, e - b));
      o.values.push_back(all.substr(b));
    }
    out.push_back(std::move(o));
  }
  return out;
}

SolveResult PluginSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  const visgate_method_v1_t* d = lib_->desc;
  auto fail = [&](const std::string& why) {
    return ExternalMethodError(name() + ": " + why + " (scene " + scene.name + ")");
  };
  if (lib_->crashed.load()) throw fail("disabled: it crashed earlier in this process (" + lib_->crash_reason + ")");

  std::vector<visgate_option_v1_t> opts;
  for (const auto& [k, v] : opt.opts) opts.push_back({k.c_str(), v.c_str()});
  char error[512] = {0};
  if (d->create && (!has_state_ || state_opts_ != opt.opts)) {
    if (has_state_ && d->free_state) d->free_state(state_);
    has_state_ = false;
    state_ = d->create(opts.data(), opts.size(), error, sizeof error);
    error[sizeof error - 1] = '\0';
    if (!state_) throw fail(std::string("create failed: ") + (error[0] ? error : "no reason given"));
    has_state_ = true;
    state_opts_ = opt.opts;
  }

  FlatScene flat;
  flatten_scene(scene, !(d->flags & VISGATE_METHOD_NO_RELATION_POINTS), flat);
  const size_t n = scene.receivers.size(), per = scene.samples_per_receiver(), words = (per + 63) / 64;
  const size_t lights = scene.lights.size();
  std::vector<uint64_t> bits(n * words, 0);
  std::vector<float> fractions(n * lights, std::nanf(""));
  visgate_output_v1_t out{};
  out.struct_size = sizeof out;
  out.visible_bits = bits.data();
  out.words_per_receiver = words;
  out.visible_fraction = fractions.data();
  out.error = error;
  out.error_size = sizeof error;

  int rc = 0, sig = 0;
  if (guard_) {
    GuardScope scope;
    sig = guarded_solve(d, state_, &flat.view, opts.data(), opts.size(), opt.seed, opt.threads, &out, &rc);
  } else {
    rc = d->solve(state_, &flat.view, opts.data(), opts.size(), opt.seed, opt.threads, &out);
  }
  if (sig != 0) {
    {
      std::lock_guard<std::mutex> lock(registry_mutex());
      if (!lib_->crashed.load()) {
        lib_->crash_reason = "crashed: " + signal_text(sig);
        lib_->crashed.store(true);
      }
    }
    throw fail("crashed: " + signal_text(sig) + " in solve; the library is disabled for the rest of this process");
  }
  error[sizeof error - 1] = '\0';
  if (rc != 0)
    throw fail("solve returned " + std::to_string(rc) + (error[0] ? std::string(": ") + error : ": no reason given"));

  SolveResult r = make_empty_result(scene);
  const uint64_t last_mask = per % 64 == 0 ? ~uint64_t(0) : (uint64_t(1) << (per % 64)) - 1;
  bool need_bits_fractions = false;
  for (size_t i = 0; i < n; ++i) {
    auto& rr = r.receivers[i];
    std::copy(bits.begin() + ptrdiff_t(i * words), bits.begin() + ptrdiff_t((i + 1) * words), rr.visible_bits.begin());
    if (words) rr.visible_bits.back() &= last_mask;
    for (size_t l = 0; l < lights; ++l) {
      const float f = fractions[i * lights + l];
      if (std::isnan(f)) need_bits_fractions = true;
      else if (!(f >= 0.0f && f <= 1.0f))
        throw fail("malformed answer: visible_fraction of receiver " + std::to_string(i) + ", light " +
                   std::to_string(l) + " is " + std::to_string(f) + ", outside [0, 1]");
    }
  }
  if (need_bits_fractions) {
    fractions_from_bits(scene, r);
    for (size_t i = 0; i < n; ++i)
      for (size_t l = 0; l < lights; ++l)
        if (!std::isnan(fractions[i * lights + l])) r.receivers[i].visible_fraction[l] = fractions[i * lights + l];
  } else {
    for (size_t i = 0; i < n; ++i)
      for (size_t l = 0; l < lights; ++l) r.receivers[i].visible_fraction[l] = fractions[i * lights + l];
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace visgate::external
