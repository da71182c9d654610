// The minimiser (see minimize.h).
#include "tools/harness/minimize.h"

#include <cmath>
#include <exception>
#include <functional>
#include <numeric>

#include "oracle/comparator.h"

namespace visgate::harness {

namespace {

// A scene with the triangles `keep` of `src` (in that order), vertices compacted in
// first-use order so that equal inputs give equal outputs.
Scene subset(const Scene& src, const std::vector<uint32_t>& keep) {
  Scene s;
  s.name = src.name;
  s.lights = src.lights;
  s.receivers = src.receivers;
  s.grid = src.grid;
  std::vector<uint32_t> remap(src.mesh.vertices.size(), UINT32_MAX);
  for (uint32_t t : keep) {
    std::array<uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      uint32_t v = src.mesh.triangles[t][k];
      if (remap[v] == UINT32_MAX) {
        remap[v] = uint32_t(s.mesh.vertices.size());
        s.mesh.vertices.push_back(src.mesh.vertices[v]);
      }
      tri[k] = remap[v];
    }
    s.mesh.triangles.push_back(tri);
  }
  return s;
}

// Rounds f to `bits` significant bits (0: zero), to nearest.
float round_bits(float f, int bits) {
  if (bits <= 0 || f == 0.0f) return 0.0f;
  int e = 0;
  double m = std::frexp(double(f), &e);  // |m| in [0.5, 1)
  double r = std::ldexp(std::round(std::ldexp(m, bits)), e - bits);
  return float(r);
}

// Significant bits of f's mantissa (0 for zero).
int mantissa_bits(float f) {
  if (f == 0.0f) return 0;
  for (int b = 1; b <= 24; ++b)
    if (round_bits(f, b) == f) return b;
  return 24;
}

}  // namespace

Result<Scene> isolate_relation(const Scene& src, size_t receiver, size_t light, long sample) {
  if (receiver >= src.receivers.size())
    return Error{src.name + ": receiver " + std::to_string(receiver) + " out of range (" +
                 std::to_string(src.receivers.size()) + " receivers)"};
  if (light >= src.lights.size())
    return Error{src.name + ": light " + std::to_string(light) + " out of range (" + std::to_string(src.lights.size()) +
                 " lights)"};
  const Light& L = src.lights[light];
  if (sample < 0 || sample >= L.samples)
    return Error{src.name + ": sample " + std::to_string(sample) + " out of range (" + std::to_string(L.samples) +
                 " samples)"};
  Scene s;
  s.name = src.name;
  s.mesh = src.mesh;
  Light l;
  l.polygon = L.polygon;
  l.samples = 1;
  l.jitter = 1;
  l.seed = L.seed;
  l.pattern = SamplePattern::Explicit;
  l.explicit_samples = {sample_position(L, int(sample), receiver)};
  Status st = prepare_light(l, s.name + ": lights[0]");
  if (!st) return st.error();
  s.lights.push_back(std::move(l));
  s.receivers.push_back(src.receivers[receiver]);
  return s;
}

Result<Scene> light_lattice_scene(const Scene& src, size_t receiver, size_t light, int grid) {
  if (receiver >= src.receivers.size() || light >= src.lights.size())
    return Error{src.name + ": pair (" + std::to_string(receiver) + ", " + std::to_string(light) + ") out of range"};
  if (grid < 1 || grid > 1024) return Error{"lattice size " + std::to_string(grid) + ": expected 1..1024"};
  const Light& L = src.lights[light];
  const size_t m = L.polygon.size();
  // Newell normal and the dropped axis (coordinates relative to the first vertex, so a
  // light far from the origin keeps its precision).
  const Vec3d o = to_double(L.polygon[0]);
  std::vector<Vec3d> p(m);
  for (size_t i = 0; i < m; ++i) p[i] = to_double(L.polygon[i]) - o;
  Vec3d n(0, 0, 0);
  for (size_t i = 0; i < m; ++i) n += cross(p[i], p[(i + 1) % m]);  // as prepare_light, relative to o
  int k = 0;
  for (int j = 1; j < 3; ++j)
    if (std::abs(n[j]) > std::abs(n[k])) k = j;
  if (!(std::abs(n[k]) > 0.0)) return Error{src.name + ": lights[" + std::to_string(light) + "]: zero area"};
  const int i1 = (k + 1) % 3, i2 = (k + 2) % 3;
  double lo1 = p[0][i1], hi1 = lo1, lo2 = p[0][i2], hi2 = lo2;
  for (const Vec3d& q : p) {
    lo1 = std::min(lo1, q[i1]), hi1 = std::max(hi1, q[i1]);
    lo2 = std::min(lo2, q[i2]), hi2 = std::max(hi2, q[i2]);
  }
  // Orientation of the projected polygon, for the strictly-inside test.
  const double orient = n[k] > 0 ? 1.0 : -1.0;
  std::vector<Vec3f> pts;
  for (int a = 0; a < grid; ++a)
    for (int b = 0; b < grid; ++b) {
      const double u = lo1 + (hi1 - lo1) * (a + 0.5) / grid, v = lo2 + (hi2 - lo2) * (b + 0.5) / grid;
      bool inside = true;
      for (size_t i = 0; i < m && inside; ++i) {
        const Vec3d& e0 = p[i];
        const Vec3d& e1 = p[(i + 1) % m];
        const double c = (e1[i1] - e0[i1]) * (v - e0[i2]) - (e1[i2] - e0[i2]) * (u - e0[i1]);
        inside = orient * c > 0.0;
      }
      if (!inside) continue;
      Vec3d x;
      x[i1] = u;
      x[i2] = v;
      x[k] = -(n[i1] * u + n[i2] * v) / n[k];  // on the plane through the first vertex
      pts.push_back(Vec3f(x + o));
    }
  if (pts.empty()) return Error{src.name + ": lights[" + std::to_string(light) + "]: no lattice point inside"};
  Scene s;
  s.name = src.name;
  s.mesh = src.mesh;
  Light l;
  l.polygon = L.polygon;
  l.samples = int(pts.size());
  l.jitter = 1;
  l.seed = L.seed;
  l.pattern = SamplePattern::Explicit;
  l.explicit_samples = std::move(pts);
  Status st = prepare_light(l, s.name + ": lights[0]");
  if (!st) return st.error();
  s.lights.push_back(std::move(l));
  // Every receiver is kept (the pair's one is `receiver` still): with coherence the
  // fragments of one receiver depend on the tree the others developed.
  s.receivers = src.receivers;
  return s;
}

std::optional<FractionWitness> find_fraction_witness(const Scene& scene, Solver& solver, const SolveOptions& options,
                                                     size_t receiver, size_t light, double tau, int grid) {
  auto w = light_lattice_scene(scene, receiver, light, grid);
  if (!w) return std::nullopt;
  SolveResult res = solver.solve(*w, options);
  oracle::RelationOracleResult exact = oracle::run_relation_oracle(*w, 1);
  oracle::Comparison cmp = oracle::compare_relations(*w, res, exact, tau);
  for (const auto& mm : cmp.mismatches)
    if (mm.receiver == receiver &&
        (mm.direction == oracle::Direction::FalseVisible || mm.direction == oracle::Direction::FalseBlocked)) {
      FractionWitness f;
      f.sample = mm.sample;
      f.margin = mm.margin;
      f.direction = oracle::direction_name(mm.direction);
      f.scene = std::move(*w);
      return f;
    }
  return std::nullopt;
}

Result<RelationVerdict> judge_relation(const Scene& scene, const CaseSpec& spec) {
  auto solver = make_solver(spec.method);
  if (!solver) return Error{"--method " + spec.method + ": unknown method"};
  if (spec.receiver >= scene.receivers.size() || spec.light >= scene.lights.size() || spec.sample < 0 ||
      spec.sample >= scene.lights[spec.light].samples)
    return Error{scene.name + ": relation (" + std::to_string(spec.receiver) + ", " + std::to_string(spec.light) + ", " +
                 std::to_string(spec.sample) + ") out of range"};
  SolveResult res;
  try {
    res = solver->solve(scene, spec.options);
  } catch (const std::exception& e) {  // an external method's failure (lib/external)
    return Error{std::string("method ") + spec.method + " failed: " + e.what()};
  }
  RelationVerdict v;
  v.method_visible = res.receivers[spec.receiver].visible(scene.light_offset(spec.light) + size_t(spec.sample));
  const Vec3f& q = sample_position(scene.lights[spec.light], int(spec.sample), spec.receiver);
  oracle::RelationAnswer a = oracle::classify_segment(scene, scene.receivers[spec.receiver].p, q);
  v.exact = a.cls;
  v.margin = a.margin;
  if (a.cls != oracle::RelationClass::Degenerate && a.margin >= spec.tau) {
    if (a.cls == oracle::RelationClass::Blocked && v.method_visible) v.direction = "false-visible";
    if (a.cls == oracle::RelationClass::Visible && !v.method_visible) v.direction = "false-blocked";
  }
  return v;
}

Result<MinimizeResult> minimize_case(const Scene& scene, const CaseSpec& spec_in) {
  CaseSpec spec = spec_in;
  if (!make_solver(spec.method)) return Error{"--method " + spec.method + ": unknown method"};
  if (!spec.direction.empty() && spec.direction != "false-visible" && spec.direction != "false-blocked")
    return Error{"direction " + spec.direction + ": only relation mismatches (false-visible, false-blocked) are minimised"};
  MinimizeResult out;
  out.triangles_before = scene.mesh.size();
  auto first = judge_relation(scene, spec);
  if (!first) return first.error();
  if (first->direction.empty())
    return Error{scene.name + ": relation (" + std::to_string(spec.receiver) + ", " + std::to_string(spec.light) + ", " +
                 std::to_string(spec.sample) + ") is not a mismatch of " + spec.method + " at tau " +
                 std::to_string(spec.tau)};
  if (spec.direction.empty()) spec.direction = first->direction;
  if (first->direction != spec.direction)
    return Error{scene.name + ": the relation is a " + first->direction + " mismatch, not " + spec.direction};

  // 1. Isolate the relation.
  auto iso = isolate_relation(scene, spec.receiver, spec.light, spec.sample);
  if (!iso) return iso.error();
  Scene cur = std::move(*iso);
  CaseSpec local = spec;
  local.receiver = 0;
  local.light = 0;
  local.sample = 0;
  auto holds = [&](const Scene& s) {
    ++out.tests;
    auto v = judge_relation(s, local);
    return v && v->direction == spec.direction;
  };
  // A method whose answer depends on other relations (shared shafts, coherence) may
  // not reproduce in isolation: then keep every receiver and sample, minimise the
  // triangles and the receiver's coordinates, and try isolating again at the end.
  bool isolated = holds(cur);
  if (!isolated) {
    cur = scene;
    cur.grid.reset();  // receivers are written as a list so their coordinates can shrink
    local = spec;
    if (!holds(cur))
      return Error{scene.name + ": the " + spec.direction + " mismatch of " + spec.method + " does not reproduce"};
  }

  bool changed = true;
  while (changed) {
    changed = false;
    // 2. ddmin over the triangles.
    std::vector<uint32_t> tris(cur.mesh.size());
    std::iota(tris.begin(), tris.end(), 0u);
    size_t n = 2;
    while (tris.size() >= 2) {
      size_t chunk = (tris.size() + n - 1) / n;
      bool reduced = false;
      std::vector<std::vector<uint32_t>> parts;
      for (size_t i = 0; i < tris.size(); i += chunk)
        parts.emplace_back(tris.begin() + long(i), tris.begin() + long(std::min(tris.size(), i + chunk)));
      for (const auto& part : parts)
        if (holds(subset(cur, part))) {
          tris = part;
          n = 2;
          reduced = true;
          break;
        }
      if (!reduced && parts.size() > 2)
        for (size_t p = 0; p < parts.size(); ++p) {
          std::vector<uint32_t> rest;
          for (size_t q = 0; q < parts.size(); ++q)
            if (q != p) rest.insert(rest.end(), parts[q].begin(), parts[q].end());
          if (holds(subset(cur, rest))) {
            tris = rest;
            n = std::max<size_t>(n - 1, 2);
            reduced = true;
            break;
          }
        }
      if (reduced) continue;
      if (n >= tris.size()) break;
      n = std::min(tris.size(), n * 2);
    }
    if (tris.size() != cur.mesh.size()) {
      cur = subset(cur, tris);
      changed = true;
    } else {
      Scene compact = subset(cur, tris);  // canonical vertex order
      if (compact.mesh.vertices != cur.mesh.vertices) cur = std::move(compact);
    }

    // 3. Shorten mantissas, one coordinate at a time, to the fewest bits that keep the
    // signature.
    auto shorten = [&](float& x, const std::function<void()>& sync) {
      int bits = mantissa_bits(x);
      float orig = x;
      for (int b = 0; b < bits; ++b) {
        float cand = round_bits(orig, b);
        if (cand == orig || !std::isfinite(cand)) continue;
        x = cand;
        sync();
        if (holds(cur)) {
          changed = true;
          return;
        }
      }
      x = orig;
      sync();
    };
    auto nothing = [] {};
    for (auto& v : cur.mesh.vertices)
      for (int k = 0; k < 3; ++k) shorten(v[k], nothing);
    for (int k = 0; k < 3; ++k) shorten(cur.receivers[local.receiver].p[k], nothing);
    if (isolated) {
      Light& light = cur.lights[0];
      auto sync_sample = [&] {
        light.jitter_points[0] = light.explicit_samples[0];
        light.jitter_boxes[0] = AABB{};
        light.jitter_boxes[0].extend(light.explicit_samples[0]);
      };
      for (int k = 0; k < 3; ++k) shorten(light.explicit_samples[0][k], sync_sample);
    } else {
      // With fewer triangles the relation may now reproduce in isolation.
      auto iso2 = isolate_relation(cur, local.receiver, local.light, local.sample);
      CaseSpec zero = local;
      zero.receiver = 0, zero.light = 0, zero.sample = 0;
      if (iso2) {
        auto v = judge_relation(*iso2, zero);
        ++out.tests;
        if (v && v->direction == spec.direction) {
          cur = std::move(*iso2);
          local = zero;
          isolated = true;
          changed = true;
        }
      }
    }
  }
  auto final_verdict = judge_relation(cur, local);
  VG_CHECK(final_verdict.ok() && final_verdict->direction == spec.direction);
  out.scene = std::move(cur);
  out.verdict = *final_verdict;
  out.receiver = local.receiver;
  out.light = local.light;
  out.sample = local.sample;
  return out;
}

}  // namespace visgate::harness
