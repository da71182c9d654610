// The `visgate` command line (DESIGN section 7). Each subcommand lives in its own
// cmd_<name>.cpp and registers itself through one add_<name> function; main.cpp lists
// them. Exit codes for every command: 0 success / nothing found, 1 mismatches found or
// defects left, 2 bad input or usage (one line on stderr naming the file and element),
// 3 internal error.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace visgate::cli {

enum Exit { kOk = 0, kFound = 1, kBadInput = 2, kInternal = 3 };

using Action = std::function<int()>;

// Prints "visgate: <message>" as one line on stderr and returns kBadInput.
int bad_input(const std::string& message);
// True when stderr is a terminal (progress bars only then).
bool stderr_is_tty();

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
