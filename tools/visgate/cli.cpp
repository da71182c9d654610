// What the visgate commands share (see cli.h).
#include "tools/visgate/cli.h"

#include <unistd.h>

#include <cstdio>
#include <sstream>

#include "lib/external/external_methods.h"
#include "lib/scene/json_exact.h"

namespace visgate::cli {

int bad_input(const std::string& message) {
  std::string line = message;
  for (auto& c : line)
    if (c == '\n') c = ' ';
  std::fprintf(stderr, "visgate: %s\n", line.c_str());
  return kBadInput;
}

int bad_input(const Error& error) { return bad_input(error.message); }

bool stderr_is_tty() { return ::isatty(2) == 1; }

void add_method_args(CLI::App* sub, MethodArgs& m, const MethodArgsHelp& help) {
  CLI::Option* method = sub->add_option("--method", m.method, help.method);
  if (help.required) method->required();
  sub->add_option("--opt", m.opts, "Method option key=value (repeatable)");
  sub->add_option("--threads", m.threads, "Threads (0: all)");
  sub->add_option("--memory-budget", m.memory_budget_mb,
                  "MB the method's growing structures may hold (iss, ssv, plucker-bsp; 0, the default: half of "
                  "physical memory, at most 8192)");
  if (help.seed) sub->add_option("--seed", m.seed, "Seed for randomised methods");
}

void add_family_args(CLI::App* sub, FamilyParams& p) {
  sub->add_option("--triangles", p.triangles, "Target blocker triangle count");
  sub->add_option("--receivers", p.receivers, "Receiver count");
  sub->add_option("--samples", p.samples, "Samples per light");
  sub->add_option("--light-scale", p.light_scale, "Scale every light polygon about its centre");
  sub->add_option("--scale-exponent", p.scale_exponent,
                  "Multiply the generated scene by 2^K (clamped to where the copy is exact)");
}

Result<Method> make_method(const MethodArgs& m) {
  Method out;
  out.solver = make_solver(m.method);
  if (!out.solver) return Error{"--method " + external::describe_unknown_method(m.method)};
  out.options.threads = m.threads;
  out.options.seed = m.seed;
  out.options.memory_budget_mb = m.memory_budget_mb;
  for (const auto& kv : m.opts) {
    auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) return Error{"--opt " + kv + ": expected key=value"};
    out.options.opts[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  if (Status st = out.solver->check_options(out.options); !st) return st.error();
  return out;
}

Result<harness::MethodSpec> method_spec(const std::string& label, const std::vector<std::string>& opts, int threads,
                                        const std::string& flag) {
  const std::string name = harness::method_of_label(label);
  auto solver = make_solver(name);
  if (!solver) return Error{flag + " " + external::describe_unknown_method(name)};
  harness::MethodSpec spec{name, SolveOptions{}, label.find('#') == std::string::npos ? "" : label};
  spec.options.threads = threads;
  for (const auto& kv : opts) {
    auto eq = kv.find('=');
    auto colon = eq == std::string::npos || eq == 0 ? std::string::npos : kv.rfind(':', eq - 1);
    if (colon == std::string::npos) return Error{"--opt " + kv + ": expected METHOD:key=value"};
    if (kv.substr(0, colon) == label) spec.options.opts[kv.substr(colon + 1, eq - colon - 1)] = kv.substr(eq + 1);
  }
  if (Status st = solver->check_options(spec.options); !st) return st.error();
  return spec;
}

Status write_output(const std::string& path, const std::string& text) {
  if (path != "-") return write_file_atomic(path, text);
  std::fwrite(text.data(), 1, text.size(), stdout);
  return {};
}

std::vector<std::string> split_list(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace visgate::cli
