// The ssv method (see ssv_solver.h).
#include "lib/ssv/ssv_solver.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <limits>

#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_solver.h"
#include "lib/ssv/integrate.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/wedge.h"
#include "lib/ssv/wedge_bsp.h"

namespace visgate::ssv {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

struct ThreadState {
  ThreadState(const mesh::PreparedMesh& m, const std::vector<Vec3f>& fp, const LightFrame& f) : integrator(m, fp, f) {}
  ReceiverIntegrator integrator;
  std::vector<uint32_t> candidates;
  std::vector<std::pair<uint32_t, int>> valid;  // edge, weight
  std::vector<uint32_t> pick, owner;  // DepthCounter::reset
  std::vector<int32_t> depth;
  double reported = 0, validated = 0, queries = 0, fallback = 0, rays = 0, inconsistent = 0, doubtful = 0;
  double t_query = 0, t_valid = 0, t_integrate = 0, t_ray = 0;
};

// Samples of one class examined for a clear reference (ReceiverIntegrator::clearance):
// a bound on the work per receiver; the first clear one is taken. Eight random samples
// all within 2^-14 S of a projected edge happen only in exactly degenerate scenes, which
// then pay one ray per sample.
constexpr int kCandidates = 8;

// Picks, among the first kCandidates samples of depth d (in sample order), the first one
// whose clearance reaches the threshold, else the one of largest clearance; `j` must
// hold some sample of depth d on entry and receives the pick. Returns whether the pick
// is clear.
bool pick_clear_sample(const ReceiverIntegrator& integ, const std::vector<int32_t>& depth, int32_t d, int& j) {
  const double need = integ.clearance_threshold();
  double best = -1.0;
  int seen = 0;
  for (size_t k = 0; k < depth.size() && seen < kCandidates; ++k) {
    if (depth[k] != d) continue;
    ++seen;
    const double c = integ.clearance(k);
    if (c > best) {
      best = c;
      j = int(k);
    }
    if (c >= need) return true;
  }
  return false;
}

}  // namespace

SolveResult SsvSolver::solve(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  const bool use_region = opt.get_bool("silhouette_regions", true);

  auto tp0 = Clock::now();
  const mesh::PreparedMesh pm = mesh::prepare_mesh(scene.mesh);
  auto t0 = Clock::now();

  raycast::EmbreeScene embree(scene.mesh, true);
  auto t1 = Clock::now();

  SolveResult result = make_empty_result(scene);
  const std::vector<Edge> edges = mesh_edges(pm);

  // Root box: the scene bounds (blockers, lights, receivers) grown by 1e-3 of the
  // diagonal so that every receiver lies strictly inside.
  AABB root = scene.bounds();
  const float grow = float(1e-3 * root.diagonal()) + std::numeric_limits<float>::min();
  root.lo -= Vec3f(grow, grow, grow);
  root.hi += Vec3f(grow, grow, grow);
  // Tolerances. M bounds the magnitude of every coordinate. A float plane test n.x - d
  // with a unit normal errs by a few ulps of M (about 4e-7 M with the rounding of n and d
  // from double); eps = 4e-6 M is ten times that. `tol` judges the double-precision
  // wedge planes (errors about 1e-15 M).
  const double M = std::max(max_component(vabs(root.lo)), max_component(vabs(root.hi)));
  const float eps = float(4e-6 * M);
  const double tol = 1e-9 * M;

  double init_seconds = 0, peak_memory = 0;
  WedgeBuildCounts counts;
  double reported = 0, validated = 0, queries = 0, fallback = 0, rays = 0, inconsistent = 0, doubtful = 0, nodes = 0;
  double t_query = 0, t_valid = 0, t_integrate = 0, t_ray = 0;

  for (size_t l = 0; l < scene.lights.size(); ++l) {
    const Light& light = scene.lights[l];
    const size_t offset = scene.light_offset(l);
    auto ti0 = Clock::now();
    const LightFrame frame = make_light_frame(light);
    // Samples off the light plane by more than 1e-5 of the light's extent (explicit
    // samples placed elsewhere) break the projection model: cast rays for that light.
    const bool light_fallback = double(frame.max_jitter_h) > 1e-5 * frame.extent;
    std::vector<Vec3f> frame_pos(pm.vertex_pos.size());
    for (size_t v = 0; v < frame_pos.size(); ++v) frame_pos[v] = frame.to_frame(pm.vertex_pos[v]);
    std::vector<Wedge> wedges;
    std::vector<uint32_t> cut_triangles;
    if (!light_fallback) {
      wedges = build_wedges(pm, edges, frame_pos, frame, tol, counts);
      for (size_t t = 0; t < pm.triangles.size(); ++t) {
        bool pos = false, neg = false;
        for (uint32_t v : pm.triangles[t].v) {
          pos |= frame_pos[v].z > 0.0f;
          neg |= frame_pos[v].z < 0.0f;
        }
        if (pos && neg) cut_triangles.push_back(uint32_t(t));
      }
    }
    WedgeBsp bsp(wedges, root, eps, use_region);
    const JitterOrder order = make_jitter_order(frame.jitter_uv, light.samples);
    init_seconds += seconds_between(ti0, Clock::now());

    tbb::enumerable_thread_specific<ThreadState> states([&] { return ThreadState(pm, frame_pos, frame); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, scene.receivers.size(), 8), [&](const tbb::blocked_range<size_t>& range) {
      ThreadState& st = states.local();
      for (size_t i = range.begin(); i != range.end(); ++i) {
        ReceiverResult& rr = result.receivers[i];
        const Vec3f& r = scene.receivers[i].p;
        if (light_fallback || !(frame.to_frame(r).z > 0.0f)) {
          auto a = Clock::now();
          for (int j = 0; j < light.samples; ++j)
            rr.set_visible(offset + size_t(j), !embree.occluded(r, sample_position(light, j, i)));
          st.fallback += light.samples;
          st.t_ray += seconds_between(a, Clock::now());
          continue;
        }
        auto a = Clock::now();
        st.candidates.clear();
        bsp.query(r, st.candidates);
        auto b = Clock::now();
        st.pick.resize(size_t(light.samples));
        st.owner.resize(light.jitter_points.size());
        for (int j = 0; j < light.samples; ++j) {
          uint32_t k = uint32_t(&sample_position(light, j, i) - light.jitter_points.data());
          st.pick[size_t(j)] = k;
          st.owner[k] = uint32_t(j) + 1;
        }
        st.integrator.begin(r, order, st.pick, st.owner);
        for (uint32_t k : st.pick) st.owner[k] = 0;
        auto c = Clock::now();
        // Validation: receiver inside the wedge and the edge a silhouette from it.
        st.valid.clear();
        for (uint32_t wi : st.candidates) {
          const Wedge& w = wedges[wi];
          if (!point_in_wedge(w, r, eps)) continue;
          int weight = st.integrator.edge_weight(edges[w.edge]);
          if (weight != 0) st.valid.emplace_back(w.edge, weight);
        }
        auto d = Clock::now();
        for (const auto& [e, weight] : st.valid) st.integrator.add_edge(edges[e], weight);
        for (uint32_t t : cut_triangles) st.integrator.add_cut(t);
        st.integrator.finish(st.depth);
        auto e = Clock::now();
        // Reference ray to a sample of minimum relative depth complexity, and a check
        // ray to a sample of the next class: it must be blocked (its depth is at least
        // one more than the minimum's, which is >= 0). Both samples are chosen clear of
        // every projected piece (ReceiverIntegrator::clearance): a sample on a projected
        // silhouette edge has a counter and an Embree answer of either side, and one
        // reference decides its whole class. When no sample of the minimum class is
        // clear among the first kCandidates, or the check ray is unblocked (some
        // near-degenerate projection corrupted the counters, e.g. a sample within
        // rounding of a sliver seen edge-on), the receiver is answered by one ray per
        // sample instead.
        int best = 0, next = -1;
        for (int j = 1; j < light.samples; ++j)
          if (st.depth[size_t(j)] < st.depth[size_t(best)]) best = j;
        const int32_t dmin = st.depth[size_t(best)];
        for (int j = 0; j < light.samples; ++j)
          if (st.depth[size_t(j)] > dmin && (next < 0 || st.depth[size_t(j)] < st.depth[size_t(next)])) next = j;
        const bool trusted = pick_clear_sample(st.integrator, st.depth, dmin, best);
        if (next >= 0) pick_clear_sample(st.integrator, st.depth, st.depth[size_t(next)], next);
        bool fallback_receiver = !trusted;
        bool open = false;
        if (trusted) {
          open = !embree.occluded(r, sample_position(light, best, i));
          const bool next_open = next >= 0 && !embree.occluded(r, sample_position(light, next, i));
          st.rays += next >= 0 ? 2 : 1;
          if (next_open) {
            fallback_receiver = true;
            st.inconsistent += 1;
          }
        } else {
          st.doubtful += 1;
        }
        if (fallback_receiver) {
          for (int j = 0; j < light.samples; ++j)
            rr.set_visible(offset + size_t(j), !embree.occluded(r, sample_position(light, j, i)));
          st.fallback += light.samples;
        } else if (open) {
          for (int j = 0; j < light.samples; ++j)
            if (st.depth[size_t(j)] == dmin) rr.set_visible(offset + size_t(j), true);
        }
        auto f = Clock::now();
        st.queries += 1;
        st.reported += double(st.candidates.size());
        st.validated += double(st.valid.size());
        st.t_query += seconds_between(a, b);
        st.t_integrate += seconds_between(b, c) + seconds_between(d, e);
        st.t_valid += seconds_between(c, d);
        st.t_ray += seconds_between(e, f);
      }
    });
    for (const ThreadState& st : states) {
      reported += st.reported;
      validated += st.validated;
      queries += st.queries;
      fallback += st.fallback;
      rays += st.rays;
      inconsistent += st.inconsistent;
      doubtful += st.doubtful;
      t_query += st.t_query;
      t_valid += st.t_valid;
      t_integrate += st.t_integrate;
      t_ray += st.t_ray;
    }
    nodes += double(bsp.node_count());
    double mem = double(bsp.memory_bytes()) + double(frame_pos.size() * sizeof(Vec3f)) +
                 double(edges.size() * sizeof(Edge));
    peak_memory = std::max(peak_memory, mem);
  }
  auto t2 = Clock::now();
  fractions_from_bits(scene, result);
  result.seconds = seconds_between(t0, t2);

  Stats& s = result.stats;
  s.set("prepare_seconds", seconds_between(tp0, t0));
  s.set("embree_build_seconds", seconds_between(t0, t1));
  s.set("init_seconds", init_seconds);
  s.set("bsp_build_query_seconds", t_query);
  s.set("validation_seconds", t_valid);
  s.set("projection_integration_seconds", t_integrate);
  s.set("reference_ray_seconds", t_ray);
  s.set("relations", double(scene.relation_count()));
  s.set("edges", double(counts.edges));
  s.set("edges_below_light", double(counts.below_light));
  s.set("edges_never_silhouette", double(counts.not_silhouette));
  s.set("wedges", double(counts.wedges));
  s.set("wedge_planes_dropped", double(counts.planes_dropped));
  s.set("bsp_nodes", nodes);
  s.set("queries", queries);
  s.set("wedges_reported", queries > 0 ? reported / queries : 0.0);
  s.set("wedges_validated", queries > 0 ? validated / queries : 0.0);
  s.set("acceptance_ratio", reported > 0 ? validated / reported : 0.0);
  s.set("reference_rays", rays);
  s.set("fallback_relations", fallback);
  s.set("inconsistent_receivers", inconsistent);
  s.set("doubtful_receivers", doubtful);
  s.set("memory_mb", peak_memory / (1024.0 * 1024.0));
  s.set("silhouette_regions", use_region ? 1.0 : 0.0);
  return result;
}

}  // namespace visgate::ssv
