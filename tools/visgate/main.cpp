// visgate: exact-geometry validation toolkit and fuzz harness for soft-shadow and
// visibility algorithms. Entry point: parses the subcommand, runs it, maps failures to
// the exit codes of DESIGN section 7.
#include <cstdio>
#include <exception>
#include <iostream>

#include "tools/visgate/cli.h"

int main(int argc, char** argv) {
  using namespace visgate::cli;
  CLI::App app{"visgate: exact-geometry validation toolkit and fuzz harness for soft-shadow and visibility algorithms"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "visgate 0.1.0");
  Action run;
  add_gen(app, run);
  add_solve(app, run);
  add_oracle(app, run);
  add_bench(app, run);
  add_render(app, run);
  add_check(app, run);
  add_minimize(app, run);
  add_gate(app, run);
  add_merge_reports(app, run);
  add_repair(app, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return bad_input(e.what());
  }
  if (!run) return bad_input("no subcommand given (see --help)");
  try {
    return run();
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "visgate: out of memory\n");
    return kInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "visgate: internal error: %s\n", e.what());
    return kInternal;
  }
}
