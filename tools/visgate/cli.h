// The `visgate` command line (DESIGN section 7). Each subcommand lives in its own
// cmd_<name>.cpp and registers itself through one add_<name> function; main.cpp lists
// them. Exit codes for every command: 0 success / nothing found, 1 mismatches found or
// defects left, 2 bad input or usage (one line on stderr naming the file and element),
// 3 internal error.
//
// What the commands share lives here once (cli.cpp): registering a subcommand with its
// options, the method options (--method, --opt, --threads, --seed), building a method
// from them, and writing an output to a file or stdout.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "lib/base/result.h"
#include "lib/scene/families.h"
#include "lib/solver.h"
#include "tools/harness/check.h"

namespace visgate::cli {

enum Exit { kOk = 0, kFound = 1, kBadInput = 2, kInternal = 3 };

using Action = std::function<int()>;

// Prints "visgate: <message>" as one line on stderr and returns kBadInput.
int bad_input(const std::string& message);
int bad_input(const Error& error);
// True when stderr is a terminal (progress bars only then).
bool stderr_is_tty();

// Registers subcommand `name`: its options live in one Opts, which binds them to the
// subcommand (Opts::bind(CLI::App*)), and `body(opts)` becomes the action when the
// subcommand is chosen.
template <class Opts, class Body>
void add_command(CLI::App& app, Action& run, const std::string& name, const std::string& help, Body body) {
  auto o = std::make_shared<Opts>();
  CLI::App* sub = app.add_subcommand(name, help);
  o->bind(sub);
  sub->callback([o, &run, body] { run = [o, body] { return body(*o); }; });
}

// The options of a command that runs one method: --method M, --opt key=value
// (repeatable), --threads N, --memory-budget MB and (when `seed`) --seed S.
struct MethodArgs {
  std::string method;
  std::vector<std::string> opts;
  int threads = 0;
  uint64_t seed = 1;
  uint64_t memory_budget_mb = 0;  // SolveOptions::memory_budget_mb (0: the default)
};
struct MethodArgsHelp {
  std::string method;  // help of --method
  bool required = true;
  bool seed = true;    // offer --seed
};
void add_method_args(CLI::App* sub, MethodArgs& m, const MethodArgsHelp& help);

// The generation options of a family's scenes (gen, check --family): --triangles,
// --receivers, --samples, --light-scale, --scale-exponent.
void add_family_args(CLI::App* sub, FamilyParams& p);

// A method and its options from MethodArgs: an unknown method, an --opt without
// "key=value" and options the method rejects are errors naming the flag.
struct Method {
  std::unique_ptr<Solver> solver;
  SolveOptions options;
};
Result<Method> make_method(const MethodArgs& m);

// One method of a command that runs several (check --methods, gate --method): LABEL is
// NAME or NAME#TAG (NAME again in a row of its own), its options the --opt items
// METHOD:key=value whose METHOD is LABEL (METHOD is everything before the last ':'
// ahead of the '=', since exec:CMD and plugin:PATH names hold colons of their own).
// `flag` names the option that listed the method in an unknown-method error.
Result<harness::MethodSpec> method_spec(const std::string& label, const std::vector<std::string>& opts, int threads,
                                        const std::string& flag);

// Writes `text` to `path` through a temporary file, or to stdout when `path` is "-".
Status write_output(const std::string& path, const std::string& text);

// "a,b,,c" -> {"a", "b", "c"}: items split at `sep`, empty ones dropped.
std::vector<std::string> split_list(const std::string& text, char sep = ',');

void add_gen(CLI::App& app, Action& run);
void add_solve(CLI::App& app, Action& run);
void add_oracle(CLI::App& app, Action& run);
void add_bench(CLI::App& app, Action& run);
void add_render(CLI::App& app, Action& run);
void add_check(CLI::App& app, Action& run);
void add_minimize(CLI::App& app, Action& run);
void add_gate(CLI::App& app, Action& run);
void add_merge_reports(CLI::App& app, Action& run);
void add_repair(CLI::App& app, Action& run);

}  // namespace visgate::cli
