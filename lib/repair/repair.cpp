// repair_mesh as a pipeline of passes (see repair.h for the guarantee): triangulate,
// analyse the input, weld, clean, orient, fill holes, split non-manifold vertices,
// analyse the output. Each pass returns its counts, recorded as one step of the report;
// the passes themselves are in triangulate.cpp, weld.cpp, clean.cpp, orient.cpp and
// fill_holes.cpp, the analysis in analysis.cpp.
#include "lib/repair/repair.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/repair/passes.h"

namespace visgate::mesh {

namespace {

using clock = std::chrono::steady_clock;

double seconds_since(clock::time_point t0) { return std::chrono::duration<double>(clock::now() - t0).count(); }

// used[v]: some triangle of `w` uses vertex v.
std::vector<uint8_t> used_vertices(const Work& w) {
  std::vector<uint8_t> used(w.pos.size(), 0);
  for (const Tri& t : w.tris)
    for (uint32_t v : t) used[v] = 1;
  return used;
}

// `tris` mapped through `rep` onto the used representatives, which keep ascending input
// order.
void compact(const std::vector<Vec3d>& pos, const std::vector<uint8_t>& used, const std::vector<uint32_t>& rep,
             const std::vector<Tri>& tris, std::vector<Vec3d>& out_pos, std::vector<Tri>& out_tris) {
  std::vector<uint32_t> id(pos.size(), kNone);
  out_pos.clear();
  for (uint32_t i = 0; i < pos.size(); ++i)
    if (used[i] && rep[i] == i) {
      id[i] = uint32_t(out_pos.size());
      out_pos.push_back(pos[i]);
    }
  out_tris.resize(tris.size());
  for (size_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) out_tris[t][size_t(k)] = id[rep[tris[t][size_t(k)]]];
}

// The input as analysed: exactly equal positions merged (an STL file shares none). Also
// welds at the tolerance (R.weld) and counts the near-duplicate vertices; records the
// "analyze_input" step, whose time includes the exact merge when T > 0.
IndexedMesh analyze_input(const Work& w, const std::vector<uint8_t>& used, bool double_precision,
                          const RepairOptions& opt, const ExactPredicates& ex, RepairResult& R, double& weld_seconds) {
  const double T = opt.weld_tolerance;
  auto t0 = clock::now();
  WeldResult exact = weld_vertices_exact(w.pos, used, 0.0, WeldMode::Chain, ex);
  const double exact_weld_seconds = seconds_since(t0);
  t0 = clock::now();
  IndexedMesh before;
  before.double_precision = double_precision;
  compact(w.pos, used, exact.rep, w.tris, before.vertices, before.triangles);
  R.before = analyze_mesh(before, ex);
  R.before_source = w.src;
  double before_seconds = seconds_since(t0);
  t0 = clock::now();
  R.weld = T == 0.0 ? exact : weld_vertices_exact(w.pos, used, T, opt.weld_mode, ex);
  R.before.defects.near_duplicate_vertices = T == 0.0 || opt.weld_mode == WeldMode::Chain
                                                 ? R.weld.merged
                                                 : weld_vertices_exact(w.pos, used, T, WeldMode::Chain, ex).merged;
  weld_seconds = seconds_since(t0) + (T == 0.0 ? exact_weld_seconds : 0.0);
  if (T != 0.0) before_seconds += exact_weld_seconds;
  R.steps.push_back(
      {"analyze_input", {{"self_intersection_pairs_tested", R.before.self_intersection_pairs_tested}}, before_seconds});
  return before;
}

// Weld: the working mesh on the representatives of R.weld.
StepRecord weld(Work& w, const std::vector<uint8_t>& used, const RepairResult& R, double seconds) {
  std::vector<Vec3d> p;
  std::vector<Tri> t;
  compact(w.pos, used, R.weld.rep, w.tris, p, t);
  w.pos = std::move(p);
  w.tris = std::move(t);
  return {"weld",
          {{"vertices_merged", R.weld.merged},
           {"clusters", R.weld.clusters},
           {"chained_clusters", R.weld.chained.size()},
           {"strict_splits", R.weld.strict_splits},
           {"unreferenced_vertices_dropped", R.unreferenced_vertices}},
          seconds};
}

// Gives every fan of a vertex beyond the first its own copy of the vertex (same
// position); ends of non-manifold edges are fans of their own faces, so this resolves
// non-manifold edges too. `cls` maps every vertex (new ones included) to the original.
size_t split_nonmanifold(Work& w, std::vector<uint32_t>& cls) {
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  UnionFind fans = corner_fans(w.tris, e);
  const size_t nt = w.tris.size();
  std::vector<uint32_t> root_vertex(nt * 3, kNone);
  std::vector<uint8_t> claimed(w.pos.size(), 0);
  size_t copies = 0;
  for (uint32_t t = 0; t < nt; ++t)
    for (uint32_t k = 0; k < 3; ++k) {
      uint32_t r = fans.find(3 * t + k);
      uint32_t v = w.tris[t][k];
      if (root_vertex[r] == kNone) {
        if (!claimed[v]) {
          claimed[v] = 1;
          root_vertex[r] = v;
        } else {
          root_vertex[r] = uint32_t(w.pos.size());
          w.pos.push_back(w.pos[v]);
          cls.push_back(cls[v]);
          ++copies;
        }
      }
      w.tris[t][k] = root_vertex[r];
    }
  return copies;
}

// Vertices that removed faces left unused go (in order), as the next run would drop them
// as unreferenced; `cls` follows.
void drop_unused_vertices(Work& w, std::vector<uint32_t>& cls) {
  std::vector<uint32_t> id(w.pos.size(), kNone);
  for (const Tri& t : w.tris)
    for (uint32_t v : t) id[v] = 0;
  uint32_t next = 0;
  for (uint32_t v = 0; v < w.pos.size(); ++v)
    if (id[v] != kNone) {
      id[v] = next;
      w.pos[next] = w.pos[v];
      ++next;
    }
  if (next == w.pos.size()) return;
  std::vector<uint32_t> c(next);
  for (uint32_t v = 0; v < cls.size(); ++v)
    if (id[v] != kNone) c[id[v]] = id[cls[v]] != kNone ? id[cls[v]] : id[v];
  cls = std::move(c);
  w.pos.resize(next);
  for (Tri& t : w.tris)
    for (uint32_t& v : t) v = id[v];
}

// Triangles in input face order (stable; hole fillers last), so that the report maps them
// to input faces by runs.
void order_by_source(Work& w, size_t nf) {
  std::vector<uint32_t> off(nf + 2, 0);
  for (uint32_t s : w.src) ++off[(s == kFilledHole ? nf : size_t(s)) + 1];
  for (size_t f = 0; f <= nf; ++f) off[f + 1] += off[f];
  std::vector<Tri> tris(w.tris.size());
  std::vector<uint32_t> src(w.src.size());
  for (size_t t = 0; t < w.tris.size(); ++t) {
    const uint32_t slot = off[w.src[t] == kFilledHole ? nf : size_t(w.src[t])]++;
    tris[slot] = w.tris[t];
    src[slot] = w.src[t];
  }
  w.tris = std::move(tris);
  w.src = std::move(src);
}

// The output and its analysis ("analyze_output" step). The analysis depends only on the
// mesh (and the vertex classes, identity unless split): when repair left the input as it
// was, the first analysis is the answer.
void analyze_output(Work& w, std::vector<uint32_t>& cls, const IndexedMesh& before, bool double_precision,
                    const RepairOptions& opt, const ExactPredicates& ex, RepairResult& R) {
  const auto t0 = clock::now();
  R.output.vertices = std::move(w.pos);
  R.output.triangles = std::move(w.tris);
  R.output.double_precision = double_precision;
  R.output_source = std::move(w.src);
  bool split_any = false;
  for (size_t v = 0; v < cls.size() && !split_any; ++v) split_any = cls[v] != v;
  const bool unchanged = !split_any && R.output.vertices == before.vertices && R.output.triangles == before.triangles;
  if (unchanged) {
    R.after = R.before;
    R.after.defects.near_duplicate_vertices = 0;
    R.after.seconds.clear();
  } else {
    R.after = analyze_mesh(R.output, ex, &cls);
  }
  const double T = opt.weld_tolerance;
  if (T > 0 && opt.weld_mode == WeldMode::Strict) {
    // Vertices strict mode refused to merge are still within T of another one.
    std::vector<uint8_t> orig(R.output.vertices.size(), 0);
    for (size_t v = 0; v < cls.size(); ++v) orig[cls[v]] = 1;
    std::vector<uint8_t> in_use(R.output.vertices.size(), 0);
    for (const Tri& t : R.output.triangles)
      for (uint32_t v : t) in_use[cls[v]] = 1;
    for (size_t v = 0; v < orig.size(); ++v) orig[v] = orig[v] && in_use[v] && cls[v] == v;
    R.after.defects.near_duplicate_vertices =
        weld_vertices_exact(R.output.vertices, orig, T, WeldMode::Chain, ex).merged;
  }
  R.output_vertex_class = std::move(cls);
  R.steps.push_back({"analyze_output",
                     {{"self_intersection_pairs_tested", unchanged ? 0 : R.after.self_intersection_pairs_tested},
                      {"reused_input_analysis", unchanged ? 1 : 0}},
                     seconds_since(t0)});
}

// Face accounting: every input face is in the output or has a removal record.
void account_faces(RepairResult& R) {
  std::vector<uint8_t> present(R.input_faces, 0), recorded(R.input_faces, 0);
  for (uint32_t s : R.output_source)
    if (s != kFilledHole) present[s] = 1;
  for (const RemovedTriangle& r : R.removed) recorded[r.face] = 1;
  for (size_t f = 0; f < R.input_faces; ++f) {
    VG_CHECK(present[f] || recorded[f]);
    if (present[f]) ++R.faces_in_output; else ++R.faces_removed;
  }
}

}  // namespace

Result<RepairResult> repair_mesh(const PolygonSoup& soup, const RepairOptions& opt, const ExactPredicates& ex) {
  if (!std::isfinite(opt.weld_tolerance) || opt.weld_tolerance < 0)
    return Error{"--weld-tolerance: must be a finite number >= 0"};
  RepairResult R;
  R.input_vertices = soup.vertices.size();
  R.input_faces = soup.faces.size();
  if (soup.faces.size() >= kFilledHole) return Error{"too many faces (at most 2^32 - 2)"};

  Work w;
  w.pos = soup.vertices;
  auto t0 = clock::now();
  auto tri = triangulate_faces(soup, w, R.removed);
  if (!tri) return tri.error();
  R.input_triangles = w.tris.size();
  R.polygons_triangulated = tri->polygons_triangulated;
  R.fan_fallbacks = tri->fan_fallbacks;
  R.repeated_cycles_collapsed = tri->repeated_cycles_collapsed;
  R.steps.push_back(tri->record(seconds_since(t0)));

  const std::vector<uint8_t> used = used_vertices(w);
  R.unreferenced_vertices = size_t(std::count(used.begin(), used.end(), uint8_t(0)));
  double weld_seconds = 0;
  IndexedMesh before = analyze_input(w, used, soup.double_precision, opt, ex, R, weld_seconds);
  if (opt.check_only) {
    R.output = std::move(before);
    R.output_source = w.src;
    std::vector<uint8_t> present(R.input_faces, 0);
    for (uint32_t s : w.src) present[s] = 1;
    R.faces_in_output = size_t(std::count(present.begin(), present.end(), uint8_t(1)));
    R.faces_removed = R.input_faces - R.faces_in_output;
    return R;
  }
  R.steps.push_back(weld(w, used, R, weld_seconds));

  t0 = clock::now();
  const CleanCounts cleaned = clean(w, ex, R.removed);
  R.steps.push_back(cleaned.record(seconds_since(t0)));

  t0 = clock::now();
  const OrientCounts oriented = orient(w, ex);
  R.steps.push_back(oriented.record(seconds_since(t0)));

  if (opt.fill_holes > 0) {
    t0 = clock::now();
    const FillCounts filled = fill_holes(w, opt.fill_holes, ex, R.holes);
    R.steps.push_back(filled.record(seconds_since(t0)));
  }

  std::vector<uint32_t> cls(w.pos.size());
  std::iota(cls.begin(), cls.end(), 0u);
  if (opt.split_nonmanifold) {
    t0 = clock::now();
    const size_t copies = split_nonmanifold(w, cls);
    R.steps.push_back({"split_nonmanifold", {{"vertex_copies_added", copies}}, seconds_since(t0)});
  }

  drop_unused_vertices(w, cls);
  order_by_source(w, R.input_faces);
  analyze_output(w, cls, before, soup.double_precision, opt, ex, R);
  account_faces(R);
  return R;
}

}  // namespace visgate::mesh
