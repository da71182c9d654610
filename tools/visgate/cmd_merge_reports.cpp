// visgate merge-reports r1.json r2.json ... -o merged.json
// Combines check reports of shards of one campaign (same tau and methods): rows are
// summed, scenes and mismatch records concatenated. Prints the merged table on stderr.
// Exit: 0 merged without mismatches, 1 the merged report holds mismatches, 2 bad input.
#include <cstdio>

#include "lib/scene/json_exact.h"
#include "tools/harness/check.h"
#include "tools/visgate/cli.h"

namespace visgate::cli {

namespace {
struct MergeOpts {
  std::vector<std::string> inputs;
  std::string out;
  void bind(CLI::App* sub) {
    sub->add_option("reports", inputs, "Report JSON files")->required();
    sub->add_option("-o,--output", out, "Merged report JSON")->required();
  }
};

int run_merge(const MergeOpts& o) {
  using namespace visgate::harness;
  CheckReport merged;
  for (const auto& path : o.inputs) {
    auto text = read_text_file(path);
    if (!text) return bad_input(text.error());
    auto r = report_from_json(*text, path);
    if (!r) return bad_input(r.error());
    Status st = merge_report(merged, *r);
    if (!st) return bad_input(path + ": " + st.error().message);
  }
  if (Status st = write_file_atomic(o.out, report_to_json(merged)); !st) return bad_input(st.error());
  std::fputs(format_table(merged).c_str(), stderr);
  return merged.mismatch_count() > 0 ? kFound : kOk;
}
}  // namespace

void add_merge_reports(CLI::App& app, Action& run) {
  add_command<MergeOpts>(app, run, "merge-reports", "Merge check reports of shards into one report", run_merge);
}

}  // namespace visgate::cli
