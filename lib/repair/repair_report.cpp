// Repair report (see repair_report.h).
#include "lib/repair/repair_report.h"

#include <algorithm>
#include <cstdio>

namespace visgate::mesh {

namespace {

using json = nlohmann::ordered_json;

json defects_json(const DefectCounts& d) {
  json j = json::object();
  for (const auto& [name, n] : d.items()) j[name] = n;
  return j;
}

template <class List, class F>
json capped(const List& list, F&& f) {
  json a = json::array();
  for (size_t i = 0; i < list.size() && i < kReportListLimit; ++i) a.push_back(f(list[i]));
  return a;
}

json face_of(const std::vector<uint32_t>& src, uint32_t tri) {
  if (tri >= src.size() || src[tri] == kFilledHole) return nullptr;
  return src[tri];
}

// Elements of the defects of one analysed mesh; triangles also name their input face.
json details_json(const Analysis& a, const std::vector<uint32_t>& src) {
  json j;
  j["vertices"] = a.vertices;
  j["triangles"] = a.triangles;
  j["edges"] = a.edges;
  j["boundary_edges"] = a.boundary_edges;
  j["components"] = a.components.size();
  j["closed_components"] = a.closed_components;
  j["cavities"] = a.cavities;
  j["component_list"] = capped(a.components, [](const ComponentInfo& c) {
    json x{{"faces", c.faces}, {"vertices", c.vertices}, {"edges", c.edges}, {"closed", c.closed},
           {"orientable", c.orientable}, {"consistent", c.consistent}, {"boundary_loops", c.boundary_loops}};
    x["genus"] = c.genus >= 0 ? json(c.genus) : json(nullptr);
    if (c.closed && c.orientable && c.consistent) x["volume_sign"] = c.volume_sign;
    if (c.depth >= 0) x["nesting_depth"] = c.depth;
    return x;
  });
  j["boundary_loop_lengths"] = capped(a.boundary_loops, [](const std::vector<uint32_t>& l) { return l.size(); });
  j["nonmanifold_edges"] = capped(a.nonmanifold_edges, [](const std::array<uint32_t, 2>& e) { return json{e[0], e[1]}; });
  j["nonmanifold_vertices"] = capped(a.nonmanifold_vertices, [](uint32_t v) { return v; });
  j["t_junctions"] = capped(a.t_junctions, [](const std::array<uint32_t, 3>& t) {
    return json{{"vertex", t[0]}, {"edge", {t[1], t[2]}}};
  });
  j["self_intersections"] = capped(a.self_intersections, [&](const std::array<uint32_t, 2>& p) {
    return json{{"triangles", {p[0], p[1]}}, {"input_faces", {face_of(src, p[0]), face_of(src, p[1])}}};
  });
  return j;
}

}  // namespace

std::vector<std::pair<std::string, size_t>> attributes_not_kept(const PolygonSoup& soup, const InputAudit& audit) {
  std::vector<std::pair<std::string, size_t>> out = {{"vertex_normals", soup.vertex_normals},
                                                     {"vertex_colors", soup.vertex_colors},
                                                     {"texcoords", soup.texcoords},
                                                     {"face_normals", soup.face_normals},
                                                     {"face_colors", soup.face_colors}};
  for (const auto& [name, n] : audit.not_kept) {
    bool merged = false;
    for (auto& [k, v] : out)
      if (k == name) {
        v = std::max(v, n);  // the reader and the audit count the same values
        merged = true;
      }
    if (!merged) out.push_back({name, n});
  }
  return out;
}

std::vector<std::array<size_t, 4>> source_runs(const std::vector<uint32_t>& source) {
  std::vector<std::array<size_t, 4>> runs;
  size_t t = 0;
  while (t < source.size() && source[t] != kFilledHole) {
    // Triangles of face source[t], then as many following faces with the same count.
    const size_t first = t, face = source[t];
    size_t per = 0;
    while (t < source.size() && source[t] == face) ++t, ++per;
    size_t faces = 1;
    for (;;) {
      size_t u = t, k = 0;
      while (u < source.size() && source[u] == face + faces && k < per) ++u, ++k;
      if (k != per || (u < source.size() && source[u] == face + faces)) break;
      t = u;
      ++faces;
    }
    runs.push_back({first, face, faces, per});
  }
  return runs;
}

std::vector<std::string> remaining_defects(const RepairResult& r, bool check_only) {
  std::vector<std::string> out;
  const DefectCounts& d = check_only ? r.before.defects : r.after.defects;
  for (const auto& [name, n] : d.items())
    if (n > 0) out.push_back(name);
  return out;
}

json repair_report_json(const RepairResult& r, const PolygonSoup& soup, const ReportContext& ctx) {
  const bool check = ctx.options.check_only;
  json j;
  j["format"] = "visgate-repair-report";
  j["version"] = 1;
  j["mode"] = check ? "check" : "repair";
  j["exit_code"] = ctx.exit_code;
  j["seconds"] = ctx.total_seconds;
  j["input"] = {{"path", ctx.input_path},
                {"sha256", ctx.input_sha256},
                {"vertices", r.input_vertices},
                {"faces", r.input_faces},
                {"triangles", r.input_triangles},
                {"polygons_triangulated", r.polygons_triangulated},
                {"double_precision", soup.double_precision},
                {"double_coordinates_restored", ctx.audit.coordinates_restored},
                {"unreferenced_vertices", r.unreferenced_vertices}};
  json attrs = json::object();
  for (const auto& [name, n] : attributes_not_kept(soup, ctx.audit)) attrs[name] = n;
  j["input"]["attributes_not_kept"] = attrs;
  j["input"]["format"] = soup.format;
  j["input"]["warnings"] = soup.warnings;
  j["input"]["repeated_cycles_collapsed"] = r.repeated_cycles_collapsed;
  if (check) {
    j["output"] = nullptr;
  } else {
    j["output"] = {{"path", ctx.output_path},
                   {"sha256", ctx.output_sha256},
                   {"vertices", r.output.vertices.size()},
                   {"triangles", r.output.triangles.size()},
                   {"coordinate_digits", r.output.double_precision ? 17 : 9},
                   {"coordinate_format", r.output.double_precision ? "double, 17 significant digits"
                                                                   : "float, shortest round trip (at most 9 digits)"}};
  }
  if (ctx.options.fill_holes > 0 && !check)
    j["holes"] = capped(r.holes, [](const HoleRecord& h) {
      json x{{"edges", h.edges}, {"filled", h.filled}};
      if (h.filled) x["triangles"] = h.triangles;
      else x["reason"] = h.reason ? h.reason : "";
      return x;
    });
  j["options"] = {{"weld_tolerance", ctx.options.weld_tolerance},
                  {"weld_mode", ctx.options.weld_mode == WeldMode::Strict ? "strict" : "chain"},
                  {"split_nonmanifold", ctx.options.split_nonmanifold},
                  {"fill_holes", ctx.options.fill_holes}};
  j["defects"]["before"] = defects_json(r.before.defects);
  j["defects"]["after"] = check ? json(nullptr) : defects_json(r.after.defects);
  json rem = json::array();
  for (const auto& n : remaining_defects(r, check)) rem.push_back(n);
  j["remaining"] = rem;
  json steps = json::array();
  for (const StepRecord& s : r.steps) {
    json c = json::object();
    for (const auto& [name, n] : s.changes) c[name] = n;
    json step = {{"name", s.name}, {"changes", c}, {"seconds", s.seconds}};
    // The analyses also give the time of each of their phases.
    const Analysis* a = s.name == "analyze_input" ? &r.before : (s.name == "analyze_output" ? &r.after : nullptr);
    if (a) {
      json phases = json::object();
      for (const auto& [name, sec] : a->seconds) phases[name] = sec;
      step["phases"] = phases;
    }
    steps.push_back(step);
  }
  j["steps"] = steps;
  // Weld clusters whose diameter exceeds T through chaining (or that strict mode split).
  j["weld"] = {{"merged_vertices", r.weld.merged},
               {"clusters", r.weld.clusters},
               {"chained_clusters", r.weld.chained.size()},
               {"strict_splits", r.weld.strict_splits},
               {"chained_cluster_list", capped(r.weld.chained, [](const WeldCluster& c) {
                  json v = json::array();
                  for (size_t i = 0; i < c.vertices.size() && i < 64; ++i) v.push_back(c.vertices[i]);
                  return json{{"size", c.vertices.size()}, {"diameter", c.diameter}, {"vertices", v}};
                })}};
  // Face accounting.
  json removed = json::object();
  for (const RemovedTriangle& t : r.removed) {
    if (!removed.contains(t.reason)) removed[t.reason] = json::array();
    if (removed[t.reason].size() < kReportListLimit) removed[t.reason].push_back(t.face);
  }
  size_t filled = 0;
  for (uint32_t s : r.output_source) filled += s == kFilledHole;
  j["faces"] = {{"input", r.input_faces},
                {"in_output", r.faces_in_output},
                {"removed_entirely", r.faces_removed},
                {"triangles_removed", r.removed.size()},
                {"triangles_added_by_hole_filling", check ? 0 : filled},
                {"removed_by_reason", removed}};
  json runs = json::array();
  if (!check)
    for (const auto& run : source_runs(r.output_source)) runs.push_back({run[0], run[1], run[2], run[3]});
  j["faces"]["output_source_runs"] = check ? json(nullptr) : runs;
  j["topology"]["before"] = details_json(r.before, r.before_source);
  j["topology"]["after"] = check ? json(nullptr) : details_json(r.after, r.output_source);
  return j;
}

std::string repair_report_table(const RepairResult& r, const PolygonSoup& soup, const ReportContext& ctx) {
  const bool check = ctx.options.check_only;
  std::string out;
  char line[256];
  std::snprintf(line, sizeof line, "%s: %zu vertices, %zu faces (%zu triangles)\n", ctx.input_path.c_str(),
                r.input_vertices, r.input_faces, r.input_triangles);
  out += line;
  {
    std::string lost;
    for (const auto& [name, n] : attributes_not_kept(soup, ctx.audit))
      if (n) lost += " " + name + "=" + std::to_string(n);
    if (!lost.empty()) out += "  attributes not kept:" + lost + "\n";
    if (ctx.audit.double_data)
      out += "  double coordinates: " + std::to_string(ctx.audit.coordinates_restored) +
             " vertices kept at double precision (the reader rounds them to float32)\n";
  }
  std::snprintf(line, sizeof line, "  %-26s %10s %10s\n", "defect", "before", check ? "" : "after");
  out += line;
  auto before = r.before.defects.items();
  auto after = r.after.defects.items();
  for (size_t i = 0; i < before.size(); ++i) {
    if (check)
      std::snprintf(line, sizeof line, "  %-26s %10zu\n", before[i].first, before[i].second);
    else
      std::snprintf(line, sizeof line, "  %-26s %10zu %10zu%s\n", before[i].first, before[i].second, after[i].second,
                    after[i].second ? "  <- left" : "");
    out += line;
  }
  for (const StepRecord& s : r.steps) {
    std::snprintf(line, sizeof line, "  step %-21s %9.3f s", s.name.c_str(), s.seconds);
    out += line;
    for (const auto& [name, n] : s.changes)
      if (n) out += "  " + name + "=" + std::to_string(n);
    out += "\n";
  }
  if (!check) {
    std::snprintf(line, sizeof line, "  faces: %zu in output, %zu removed (see report); output %zu vertices, %zu triangles\n",
                  r.faces_in_output, r.faces_removed, r.output.vertices.size(), r.output.triangles.size());
    out += line;
  }
  auto rem = remaining_defects(r, check);
  if (rem.empty()) {
    out += check ? "  clean\n" : "  clean after repair\n";
  } else {
    out += check ? "  defects:" : "  defects left:";
    for (const auto& n : rem) out += " " + n;
    out += "\n";
  }
  return out;
}

}  // namespace visgate::mesh
