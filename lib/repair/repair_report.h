// The `visgate repair` report (DESIGN section 7): a JSON document (format
// "visgate-repair-report", version 1) with the input and output hashes, the options and
// tolerances, every defect count before and after, every step's changes and time, the
// accounting of every input face, and the remaining defects with their elements; and the
// human table printed on stderr.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "lib/repair/repair.h"
#include "lib/repair/repair_input.h"

namespace visgate::mesh {

struct ReportContext {
  std::string input_path, input_sha256;
  std::string output_path, output_sha256;  // empty with --check
  RepairOptions options;
  InputAudit audit;  // what the reader does not keep (attributes), double data restored
  int exit_code = 0;
  double total_seconds = 0.0;
};

// Lists longer than this are cut in the report (their full counts are always given).
// The face accounting (output_source_runs) is never cut.
constexpr size_t kReportListLimit = 10000;

// Attributes the output does not keep: the five the reader counts (vertex_normals,
// vertex_colors, texcoords, face_normals, face_colors; always present) and every other
// one the audit found, by name.
std::vector<std::pair<std::string, size_t>> attributes_not_kept(const PolygonSoup& soup, const InputAudit& audit);

// Runs [first_output_triangle, first_input_face, faces, triangles_per_face]: output
// triangles first .. first + faces * triangles_per_face - 1 come from input faces
// first_input_face .. + faces - 1, triangles_per_face consecutive ones each. Output
// triangles after the last run were added by hole filling. Needs a non-decreasing
// `source` (RepairResult::output_source).
std::vector<std::array<size_t, 4>> source_runs(const std::vector<uint32_t>& source);

nlohmann::ordered_json repair_report_json(const RepairResult& r, const PolygonSoup& soup, const ReportContext& ctx);
// Defect table (before / after) and step timings, for a terminal.
std::string repair_report_table(const RepairResult& r, const PolygonSoup& soup, const ReportContext& ctx);
// Names of the defects left (after repair; with check_only, those of the input).
std::vector<std::string> remaining_defects(const RepairResult& r, bool check_only);

}  // namespace visgate::mesh
