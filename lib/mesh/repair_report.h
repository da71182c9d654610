// The `visgate repair` report (DESIGN section 7, issue 9): a JSON document (format
// "visgate-repair-report", version 1) with the input and output hashes, the options and
// tolerances, every defect count before and after, every step's changes and time, the
// accounting of every input face, and the remaining defects with their elements; and the
// human table printed on stderr.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lib/mesh/repair.h"

namespace visgate::mesh {

struct ReportContext {
  std::string input_path, input_sha256;
  std::string output_path, output_sha256;  // empty with --check
  RepairOptions options;
  int exit_code = 0;
  double total_seconds = 0.0;
};

// Lists longer than this are cut in the report (their full counts are always given).
constexpr size_t kReportListLimit = 10000;

nlohmann::ordered_json repair_report_json(const RepairResult& r, const PolygonSoup& soup, const ReportContext& ctx);
// Defect table (before / after) and step timings, for a terminal.
std::string repair_report_table(const RepairResult& r, const ReportContext& ctx);
// Names of the defects left (after repair; with check_only, those of the input).
std::vector<std::string> remaining_defects(const RepairResult& r, bool check_only);

}  // namespace visgate::mesh
