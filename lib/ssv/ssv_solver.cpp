// The ssv method (see ssv_solver.h).
#include "lib/ssv/ssv_solver.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <array>
#include <optional>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lib/accel/bvh.h"
#include "lib/base/memory_budget.h"
#include "lib/geom/float_mode.h"
#include "lib/geom/lanes.h"
#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_scene.h"
#include "lib/ssv/edge_tree.h"
#include "lib/ssv/integrate.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/occluders.h"
#include "lib/ssv/packet_caster.h"
#include "lib/ssv/wedge.h"
#include "lib/ssv/wedge_bsp.h"
#include "lib/ssv/wedge_scatter.h"

namespace visgate::ssv {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// The per-receiver counters of the stats (reference rays, fallbacks, phase times); one
// per thread, summed per light in the threads' order.
struct Counts {
  double reported = 0, validated = 0, queries = 0, fallback = 0, rays = 0, inconsistent = 0, doubtful = 0,
         unchecked = 0, edge_rays = 0;
  double unclear_rays = 0, packet_undecided = 0;
  double t_query = 0, t_valid = 0, t_integrate = 0, t_ray = 0;
  Counts& operator+=(const Counts& o) {
    reported += o.reported;
    validated += o.validated;
    queries += o.queries;
    fallback += o.fallback;
    rays += o.rays;
    inconsistent += o.inconsistent;
    doubtful += o.doubtful;
    unchecked += o.unchecked;
    edge_rays += o.edge_rays;
    unclear_rays += o.unclear_rays;
    packet_undecided += o.packet_undecided;
    t_query += o.t_query;
    t_valid += o.t_valid;
    t_integrate += o.t_integrate;
    t_ray += o.t_ray;
    return *this;
  }
};

// wedge_index=edges: wedge_edge's answers by mesh edge, one byte each, kept by a thread
// across the lights of a solve: entry tag << 1 | answer, where the tag (1 to 127) names
// the light within its cycle of 127 lights; a thread zeroes the bytes when it starts a
// light of a new cycle, so an entry of another light never matches. A dense scanned mesh
// hands each thread tens of thousands of distinct candidates per light, which a small
// direct-mapped memo recomputed about one time in four (CGAL's armadillo); zeroing once
// per cycle instead of once per light keeps the scan family's ten lights of 450k edges
// from paying ten fills.
struct WedgeMemo {
  std::vector<uint8_t> known;
  size_t cycle = SIZE_MAX;
  // Ready for light `l` of a mesh of `edges` edges; returns the light's tag.
  uint8_t start(size_t l, size_t edges) {
    if (cycle != l / kLights || known.size() != edges) known.assign(edges, 0);
    cycle = l / kLights;
    return uint8_t(l % kLights + 1);
  }
  static constexpr size_t kLights = 127;
};

struct ThreadState {
  ThreadState(const mesh::PreparedMesh& m, PlaneSource planes, FramePositions fp, const LightFrame& f)
      : integrator(m, planes, std::move(fp), f) {}
  ReceiverIntegrator integrator;
  std::vector<WedgeState> candidates;
  std::vector<uint32_t> edge_candidates;  // wedge_index=edges
  std::vector<uint32_t> edge_starts;      // the edge tree's frontier of the current batch
  // wedge_index=edges: the batch's receivers' frusta and candidates (EdgeTree::query_batch);
  // `batched` points at the current receiver's list while it is integrated.
  std::vector<EdgeFrustum> batch_frusta;
  std::vector<size_t> batch_receivers;
  std::vector<std::vector<uint32_t>> batch_lists;
  std::vector<uint32_t>* batched = nullptr;
  std::vector<std::pair<uint32_t, int>> valid;  // edge, weight
  // wedge_index=edges: this thread's WedgeMemo and this light's tag in it (set on the
  // thread's first receiver of the light).
  WedgeMemo* wedge_memo = nullptr;
  uint8_t wedge_tag = 0;
  std::vector<Vec3f> fan;      // cast_fan's sample points
  std::vector<uint32_t> pick;  // DepthCounter::reset
  std::vector<int32_t> depth;
  DepthCounter::Classes classes{};  // of `depth` (DepthCounter::finish_classes)
  Counts c;
  // The last reference answer of this thread: which ranged ray to cast first. It only
  // changes how many rays are cast (stat reference_rays), never an answer.
  bool expect_blocked = false;
};

// Float mode: every SSV computation runs in an IeeeFloatMode scope (lib/geom/float_mode.h:
// Embree sets FTZ/DAZ in TBB workers).

// Slivers. A triangle whose width 2 area / L (L its longest edge) is at most 2^-20 L
// is left out of the integration and of the ray scenes alike. It blocks only segments
// that pass within that width of its long edges, so every relation it decides has a
// margin of at most 2^-20 L / diagonal < 1e-6, below tau; no relation it leaves
// visible can change. Kept, it defeats every float ray test: points on the supporting
// line of its long edges, far outside it, get edge functions that are all zero after
// rounding, in Embree's robust intersector and in the double-precision test of
// lib/raycast alike. Leaving it out of both keeps the counters and the rays about the
// same scene. Zero-area triangles, which never block, go the same way.
bool is_sliver(const TriangleSoup& soup, const std::array<uint32_t, 3>& t) {
  const Vec3d a = to_double(soup.vertices[t[0]]), b = to_double(soup.vertices[t[1]]), c = to_double(soup.vertices[t[2]]);
  const Vec3d ab = b - a, bc = c - b, ca = a - c;
  const double l2 = std::max(dot(ab, ab), std::max(dot(bc, bc), dot(ca, ca)));
  const double area2 = length(cross(ab, c - a));  // twice the area
  // width = area2 / L <= 2^-20 L  <=>  area2 <= 2^-20 L^2
  return area2 <= 0x1p-20 * l2;
}

// The soup without its slivers; nullopt when it has none (the caller keeps using the
// scene's soup: no copy of a dense mesh).
std::optional<TriangleSoup> without_slivers(const TriangleSoup& soup, size_t& dropped) {
  size_t first = 0;
  while (first < soup.triangles.size() && !is_sliver(soup, soup.triangles[first])) ++first;
  if (first == soup.triangles.size()) return std::nullopt;
  TriangleSoup out;
  out.vertices = soup.vertices;
  out.triangles.reserve(soup.triangles.size());
  out.triangles.assign(soup.triangles.begin(), soup.triangles.begin() + long(first));
  for (size_t k = first; k < soup.triangles.size(); ++k) {
    if (is_sliver(soup, soup.triangles[k])) {
      ++dropped;
      continue;
    }
    out.triangles.push_back(soup.triangles[k]);
  }
  return out;
}

// Scene::bounds() without its pass over every triangle corner (900k at scan 300k): when
// `pm` was prepared from the scene's own mesh, its vertices are the positions of that
// mesh's corners (prepare_mesh welds equal positions, -0 with +0, and drops unused
// vertices), so their box holds the same floats, up to the sign of a zero bound, which no
// use below reads (M takes magnitudes; grow, min_node and the root box differences).
AABB scene_bounds(const Scene& scene, const mesh::PreparedMesh& pm, bool pm_of_scene_mesh) {
  if (!pm_of_scene_mesh) return scene.bounds();
  LanesBox b;
  for (const Vec3f& v : pm.vertex_pos) b.add(v);
  return scene.bounds(b.box());
}

// Rays. Every ray SSV casts (references, checks, the rays of doubtful and unclear
// samples and of lights answered by rays) asks Embree's robust scene
// (RTC_SCENE_FLAG_ROBUST, watertight: no misses along shared edges) with lib/raycast's
// hit verification: every candidate hit is confirmed by the double-precision test of
// the same query (segment_hits_triangle, or its ranged form), and one it does not
// confirm is dropped (counted in stats as ray_disputes). The robust intersector can
// report hits on the supporting line of a nearly zero-area triangle far outside it
// (corpus/embree-robust/).
class Caster {
 public:
  // Embree's low-quality (Morton) build: SSV casts about one reference ray per receiver
  // and light, so the build dominates the caster's cost (answers do not depend on it);
  // paired quads halve its primitives (embree_scene.h; `embree_quads`).
  Caster(const TriangleSoup& soup, bool quads)
      : robust_(soup, true, true, raycast::BuildQuality::low,
                quads ? raycast::Primitives::paired_quads : raycast::Primitives::triangles) {}
  bool occluded(const Vec3f& from, const Vec3f& to) const { return robust_.occluded(from, to); }
  bool occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar) const {
    return robust_.occluded(from, to, tnear, tfar);
  }
  // The same, also telling whether the verification rejected a candidate hit.
  bool occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar, bool& disputed) const {
    return robust_.occluded(from, to, tnear, tfar, disputed);
  }
  size_t disputes() const { return robust_.rejected_hits(); }
  // occluded(from, to[k]) for k < n as Embree packets (EmbreeScene::occluded_fan: the same
  // verification; packet and single-ray kernels differ only at Embree's own float ties).
  void occluded_fan(const Vec3f& from, const Vec3f* to, int n, bool* out) const { robust_.occluded_fan(from, to, n, out); }

 private:
  raycast::EmbreeScene robust_;  // hit verification on (the default)
};

// Reference rays (docs/methods/ssv.md, "The reference ray"). The counters give each
// sample its depth complexity up to one constant per receiver; one ray to a point of the
// minimum class tells whether that class is visible (the rest is then blocked), and a
// check ray to the next class must find it blocked. One ray decides a whole class, so
// it must not be near-degenerate:
// - its light point q is a sample clear of every projected piece (clearance), up to
//   kCandidates samples of the class tried in sample order;
// - q is offset from the sample by a quarter of the clearance threshold in a hashed
//   direction (general position, same depth complexity), unless float spacing cannot
//   hold the offset or it would leave L' (reference_point);
// - hits within kEndZone (in t) of either end are told apart from interior hits by two
//   ranged rays (ranged_answer): 2^-18 is about 30 times the relative error of Embree's
//   t and below tau, so an end hit is never taken for an interior one;
// - a miss whose verification rejected a candidate hit (`disputed`) is ambiguous: the
//   segment passes within Embree's rounding of a triangle edge that q may lie on.
// An ambiguous answer moves on to the next candidate; the outcome does not depend on
// which ray is cast first.
enum class RefAnswer { Visible, Blocked, Ambiguous, NoCandidate };

constexpr int kCandidates = 8;
// Depth given to unclear samples: never a class (DepthCounter::finish).
constexpr int32_t kUnclear = std::numeric_limits<int32_t>::max();
constexpr float kEndZone = 0x1p-18f;

struct RefContext {
  const Caster& embree;
  const Light& light;
  const LightFrame& frame;
  const ReceiverIntegrator& integ;
  const std::vector<int32_t>& depth;
  const Vec3f& r;
  size_t receiver, light_index;
};

RefAnswer ranged_answer(const RefContext& c, const Vec3f& q, bool expect_blocked, double& rays) {
  // Ray A over [0, 1 + 2^-18]: a miss is Visible only without a dispute; a hit leaves
  // the answer to ray B (Ambiguous here).
  auto ray_a = [&] {
    rays += 1;
    bool disputed = false;
    const bool hit = c.embree.occluded(c.r, q, 0.0f, 1.0f + kEndZone, disputed);
    return hit || disputed ? RefAnswer::Ambiguous : RefAnswer::Visible;
  };
  // Ray B over [2^-18, 1 - 2^-18]: a hit is Blocked.
  auto ray_b = [&] {
    rays += 1;
    return c.embree.occluded(c.r, q, kEndZone, 1.0f - kEndZone);
  };
  if (expect_blocked) return ray_b() ? RefAnswer::Blocked : ray_a();
  rays += 1;
  bool disputed = false;
  if (!c.embree.occluded(c.r, q, 0.0f, 1.0f + kEndZone, disputed))
    return disputed ? RefAnswer::Ambiguous : RefAnswer::Visible;  // B misses too
  return ray_b() ? RefAnswer::Blocked : RefAnswer::Ambiguous;
}

// The reference point of sample j (see above): world position, rounded once.
Vec3f reference_point(const RefContext& c, int j) {
  const Vec3f s = sample_position(c.light, j, c.receiver);
  const double step = 0.25 * c.integ.clearance_threshold();
  const uint64_t h = relation_hash(c.receiver * 0x9E3779B97F4A7C15ull + c.light_index, uint64_t(j), 0x55u);
  const double phi = double(h >> 11) * 0x1p-53 * 6.283185307179586;
  const Vec3d qd = to_double(s) + c.frame.U * (step * std::cos(phi)) + c.frame.V * (step * std::sin(phi));
  const Vec3f q(qd);
  // Keep q only when its rounding left it within half the threshold of the sample.
  const Vec3d fs = c.frame.to_local(s), fq = c.frame.to_local(q);
  const double du = fq.x - fs.x, dv = fq.y - fs.y;
  if (!(du * du + dv * dv <= 4.0 * step * step)) return s;
  // And only inside L' (closed), where every sample lies (light_frame.h): the projected
  // pieces are clipped to L', so outside it a shadow boundary may lie between the sample
  // and q unseen by the clearance (corpus/ssv/other/a5f02684...). Both in a convex L',
  // the segment between them is in it too.
  auto in_poly = [&](const Vec3d& f) {
    const std::vector<Vec2f>& P = c.frame.poly;
    for (size_t k = 0; k < P.size(); ++k) {
      const Vec2f& a = P[k];
      const Vec2f& b = P[(k + 1) % P.size()];
      const double ex = double(b.u) - double(a.u), ey = double(b.v) - double(a.v);
      if (ex * (f.y - double(a.v)) - ey * (f.x - double(a.u)) < 0) return false;
    }
    return true;
  };
  if (!in_poly(fq)) return s;
  return q;
}

// The answer for the class of depth d: the first conclusive one among its first
// kCandidates samples that are clear, else Ambiguous, or NoCandidate when none of them
// is clear.
RefAnswer class_answer(const RefContext& c, int32_t d, bool expect_blocked, double& rays) {
  int seen = 0;
  bool cast = false;
  for (size_t k = 0; k < c.depth.size() && seen < kCandidates; ++k) {
    if (c.depth[k] != d) continue;
    ++seen;
    if (!c.integ.clear(k)) continue;
    cast = true;
    const RefAnswer a = ranged_answer(c, reference_point(c, int(k)), expect_blocked, rays);
    if (a != RefAnswer::Ambiguous) return a;
  }
  return cast ? RefAnswer::Ambiguous : RefAnswer::NoCandidate;
}

// The check: the first conclusive answer for the classes above dmin, lowest first, up to
// kCheckClasses of them (a class whose samples all lie on projected pieces, such as the
// inside of a sliver, has no clear candidate and the next one is tried). NoCandidate
// when no sample above dmin is clear among them: every such sample is within rounding
// distance of a projected piece, a near-degenerate relation whose own answer is outside
// the gate, and the minimum class stands on its own clear reference.
constexpr int kCheckClasses = 4;

RefAnswer check_answer(const RefContext& c, int32_t dmin, int32_t second, double& rays) {
  int32_t d = dmin;
  bool cast = false;
  for (int k = 0; k < kCheckClasses; ++k) {
    // The next class above d (the second-lowest is known from the caller's scan).
    int32_t up = second;
    if (k > 0) {
      up = std::numeric_limits<int32_t>::max();
      for (int32_t x : c.depth) up = std::min(up, x > d ? x : std::numeric_limits<int32_t>::max());
    }
    if (up == std::numeric_limits<int32_t>::max()) break;
    const RefAnswer a = class_answer(c, up, true, rays);
    if (a == RefAnswer::Visible || a == RefAnswer::Blocked) return a;
    cast |= a == RefAnswer::Ambiguous;
    d = up;
  }
  return cast ? RefAnswer::Ambiguous : RefAnswer::NoCandidate;
}

// Grazing receivers. Frame coordinates are computed in double from p - origin, so a
// height carries an absolute error of a few 2^-53 |p - origin|. Every point that
// matters for a receiver r lies in the pyramid from r over L', within
// S = E + |r_u| + |r_v| + h_r of the origin (E the light's extent): heights are known to
// about 2^-50 S. The projection scales a point's offset from r (at most S) by
// h_r / (h_r - x_h); for points on or near the light plane (cut points, vertices on it)
// a height error d moves the projection by d / h_r of that offset. With h_r > 2^-20 S
// that is below 2^-30 S, far below the counter's margin (1e-6 of the light-plane
// magnitudes) and the clearance threshold (2^-16 S). Below it the receiver lies in the
// light plane up to rounding noise: the side planes of its pyramid and the projection
// are meaningless, and the counters may put visible and blocked samples in one class.
// Such a receiver sees the light at an angle below 2^-20 and is answered by one ray per
// sample, like receivers on or behind the light plane.
bool grazing_receiver(const LightFrame& frame, const Vec3f& r) {
  const Vec3d f = frame.to_local(r);
  const double S = frame.extent + std::abs(f.x) + std::abs(f.y) + std::abs(f.z);
  return !(f.z > 0x1p-20 * S);
}

// One light's data shared by its receivers: the frame, the wedges and their BSP, the
// light-plane cuts and the sample strips (paper 001 section 2.1 and 4.1).
struct LightSetup {
  const Light& light;
  size_t index, offset;
  const LightFrame& frame;
  bool light_fallback;  // the projection model does not hold: rays for every relation
  const std::vector<Wedge>& wedges;
  const std::vector<uint32_t>& cut_triangles;
  WedgeBsp* bsp;  // lazy: queries refine it (thread-safe, wedge_bsp.h); or null:
  WedgeScatter* scatter;  // the candidates scattered through the receiver tree
  const ReceiverTree& tree;
  const SampleStrips& strips;
  const std::vector<uint8_t>& occluded;  // per receiver: blocked by an occluder (occluders.h)
  const EdgeTree* edge_tree = nullptr;   // wedge_index=edges: candidates per receiver, no wedges
  // edge_rays: a receiver with more candidates than this is answered by its rays (0: off).
  uint32_t ray_limit = 0;
  // ray_solve: every receiver is answered by its rays, without candidates (no index).
  bool all_rays = false;
  // packet_rays: per 64 samples, their order for PacketCaster::cast (packet_order).
  std::vector<uint8_t> packet_order = {};
};

// Per-scene data: the blocker mesh, its edges and the ray caster.
struct SceneSetup {
  const Scene& scene;
  const Caster& embree;
  const std::vector<Edge>& edges;
  float eps;
  const mesh::PreparedMesh& pm;
  double tol;                           // build_wedges' tolerance
  const PacketCaster* packets = nullptr;  // packet_rays: cast_fan's shared-origin packets
};

// wedge_index=edges: the edges build_wedges would give a wedge, among the receiver's
// candidates (edge_tree.h), by the same tests: some incident triangle active and some
// endpoint not below the light plane, and for a pair of active triangles, not a
// silhouette from no point of L' (wedge.h light_side). What the wedges' boxes would
// exclude beyond that has weight 0 or misses the frustum (edge_tree.h).
bool wedge_edge(const SceneSetup& sc, const ReceiverIntegrator& integ, const LightFrame& frame, const Edge& e) {
  const FramePositions& fp = integ.positions();
  auto active = [&](int32_t t) {
    if (t < 0) return false;
    const auto& v = sc.pm.triangles[size_t(t)].v;
    return fp.h(v[0]) > 0.0 || fp.h(v[1]) > 0.0 || fp.h(v[2]) > 0.0;
  };
  const bool act1 = active(e.t1), act2 = active(e.t2);
  if (!(act1 || act2) || (fp.h(e.a) < 0.0 && fp.h(e.b) < 0.0)) return false;
  if (!(act1 && act2)) return true;
  const int s1 = light_side(integ.plane(size_t(e.t1)), frame.poly_world, sc.tol);
  return s1 == 0 || s1 != light_side(integ.plane(size_t(e.t2)), frame.poly_world, sc.tol);
}

// One ray per sample of the light (the fallback of every receiver-level doubt).
void cast_all(const SceneSetup& sc, const LightSetup& ls, size_t i, ReceiverResult& rr) {
  const Vec3f& r = sc.scene.receivers[i].p;
  for (int j = 0; j < ls.light.samples; ++j)
    rr.set_visible(ls.offset + size_t(j), !sc.embree.occluded(r, sample_position(ls.light, j, i)));
}

// packet_rays: the samples of each run of 64 ordered by the Morton code of their jitter
// points' mean on an 8 x 8 grid over the light frame (a stratified 8 x 8 light: 2 x 4
// strata per 8 lanes of PacketCaster's box tests, which skip 8 lanes that all miss).
std::vector<uint8_t> packet_order(const LightFrame& frame, const Light& light) {
  const int samples = light.samples, jitter = light.jitter;
  std::vector<Vec2f> centre(static_cast<size_t>(samples));
  float ulo = INFINITY, uhi = -INFINITY, vlo = INFINITY, vhi = -INFINITY;
  for (int j = 0; j < samples; ++j) {
    double u = 0, v = 0;
    for (int k = 0; k < jitter; ++k) {
      const Vec2f& c = frame.jitter_uv[size_t(j) * size_t(jitter) + size_t(k)];
      u += double(c.u), v += double(c.v);
    }
    centre[size_t(j)] = {float(u / jitter), float(v / jitter)};
    ulo = std::min(ulo, centre[size_t(j)].u), uhi = std::max(uhi, centre[size_t(j)].u);
    vlo = std::min(vlo, centre[size_t(j)].v), vhi = std::max(vhi, centre[size_t(j)].v);
  }
  auto cell = [](float x, float lo, float hi) {
    const float t = hi > lo ? (x - lo) / (hi - lo) * 8.0f : 0.0f;
    return t >= 0.0f ? unsigned(std::min(t, 7.0f)) : 0u;  // NaN: 0
  };
  std::vector<uint8_t> order(static_cast<size_t>(samples));
  for (int j0 = 0; j0 < samples; j0 += 64) {
    const int n = std::min(64, samples - j0);
    uint16_t key[64];
    for (int k = 0; k < n; ++k) {
      const Vec2f& c = centre[size_t(j0 + k)];
      const unsigned iu = cell(c.u, ulo, uhi), iv = cell(c.v, vlo, vhi);
      unsigned code = 0;
      for (int b = 0; b < 3; ++b) code |= (iu >> b & 1u) << (2 * b) | (iv >> b & 1u) << (2 * b + 1);
      key[k] = uint16_t(code << 6 | unsigned(k));
    }
    std::sort(key, key + n);
    for (int k = 0; k < n; ++k) order[size_t(j0 + k)] = uint8_t(key[k] & 63u);
  }
  return order;
}

// One ray per sample from the receiver, 16 at a time (the edge_rays rule): the same
// verified rays as cast_all, traced as Embree packets (EmbreeScene::occluded_fan). The
// light points as sample_position's, with the hash prefix taken once per receiver
// (relation_hash_step); the visible bits, cleared on entry, set 16 at a time.
void cast_fan(ThreadState& st, const SceneSetup& sc, const LightSetup& ls, size_t i, ReceiverResult& rr) {
  const Vec3f& r = sc.scene.receivers[i].p;
  const int samples = ls.light.samples;
  const uint64_t prefix = relation_hash_prefix(i, ls.light.seed), jitter = uint64_t(ls.light.jitter);
  st.fan.resize(size_t(samples));
  for (int j = 0; j < samples; ++j)
    st.fan[size_t(j)] = ls.light.jitter_point(j, int(relation_hash_step(prefix, uint64_t(j)) % jitter));
  if (sc.packets != nullptr) {
    // Up to 64 at a time; the undecided ones by the verified ray, one by one.
    for (int j = 0; j < samples; j += 64) {
      const int n = std::min(64, samples - j);
      uint64_t blocked = 0, undecided = 0;
      sc.packets->cast(r, st.fan.data() + j, ls.packet_order.data() + j, n, blocked, undecided);
      const uint64_t all = n >= 64 ? ~uint64_t(0) : (uint64_t(1) << n) - 1;
      uint64_t visible = all & ~blocked & ~undecided;
      st.c.packet_undecided += double(__builtin_popcountll(undecided));
      for (uint64_t bits = undecided; bits != 0; bits &= bits - 1) {
        const int k = __builtin_ctzll(bits);
        if (!sc.embree.occluded(r, st.fan[size_t(j + k)])) visible |= uint64_t(1) << k;
      }
      const size_t bit = ls.offset + size_t(j), sh = bit & 63;
      rr.visible_bits[bit >> 6] |= visible << sh;
      if (sh + size_t(n) > 64) rr.visible_bits[(bit >> 6) + 1] |= visible >> (64 - sh);
    }
    return;
  }
  for (int j = 0; j < samples; j += 16) {
    const int n = std::min(16, samples - j);
    bool hit[16];
    sc.embree.occluded_fan(r, st.fan.data() + j, n, hit);
    uint64_t visible = 0;
    for (int k = 0; k < n; ++k) visible |= uint64_t(!hit[k]) << k;
    const size_t bit = ls.offset + size_t(j), sh = bit & 63;
    rr.visible_bits[bit >> 6] |= visible << sh;
    if (sh + size_t(n) > 64) rr.visible_bits[(bit >> 6) + 1] |= visible >> (64 - sh);
  }
}

// Bits of the minimum class dmin, set a word at a time (the bits start cleared), four
// samples per SSE2 compare.
void set_class_bits(ReceiverResult& rr, size_t offset, int samples, const std::vector<int32_t>& depth,
                    int32_t dmin) {
  for (int j = 0; j < samples;) {
    const size_t bit = offset + size_t(j);
    const int run = std::min(samples - j, 64 - int(bit & 63));
    uint64_t word = 0;
    int k = 0;
#if defined(__SSE2__)
    const __m128i dm = _mm_set1_epi32(dmin);
    for (; k + 4 <= run; k += 4) {
      const __m128i x = _mm_loadu_si128(reinterpret_cast<const __m128i*>(depth.data() + j + k));
      word |= uint64_t(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(x, dm)))) << k;
    }
#endif
    for (; k < run; ++k) word |= uint64_t(depth[size_t(j + k)] == dmin) << k;
    rr.visible_bits[bit >> 6] |= word << (bit & 63);
    j += run;
  }
}

// Paper 001 section 2.1 for one receiver: BSP query, validation of the wedges found
// (receiver inside the wedge, the edge a silhouette from it), projection and
// integration into per-sample depth complexity (st.depth, st.classes).
// `pos`: the receiver's tree-order position (its scattered candidates) when ls.scatter.
// Returns false, integrating nothing, when the receiver has more than ls.ray_limit
// candidates (edge_rays: its rays cost less than their integration).
bool integrate_receiver(ThreadState& st, const SceneSetup& sc, const LightSetup& ls, size_t i, uint32_t pos) {
  const Vec3f& r = sc.scene.receivers[i].p;
  auto a = Clock::now();
  st.candidates.clear();
  size_t found = 0;
  if (ls.edge_tree && st.batched) st.edge_candidates.swap(*st.batched);
  else if (ls.edge_tree)
    ls.edge_tree->query(EdgeFrustum(ls.frame, r), ls.frame, sc.eps, st.edge_starts, st.edge_candidates, ls.ray_limit);
  else if (ls.bsp) ls.bsp->query(r, st.candidates);
  if (ls.edge_tree) found = st.edge_candidates.size();
  else if (ls.bsp) found = st.candidates.size();
  else found = size_t(ls.scatter->end(pos) - ls.scatter->begin(pos));
  if (ls.ray_limit > 0 && found > ls.ray_limit) {
    st.c.t_query += seconds_between(a, Clock::now());
    return false;
  }
  if (!ls.edge_tree && !ls.bsp) st.candidates.insert(st.candidates.end(), ls.scatter->begin(pos), ls.scatter->end(pos));
  auto b = Clock::now();
  // The jitter point of every sample (sample_position, DESIGN section 3): hash prefix
  // once per receiver (jitter_picks).
  jitter_picks(relation_hash_prefix(i, ls.light.seed), ls.light.samples, ls.light.jitter, st.pick);
  st.integrator.begin(r, ls.strips, st.pick);
  auto c = Clock::now();
  // Validation. Only the planes still active in the node the wedge was found in are
  // tested: the others contain the node's box, hence r. Accepting a wedge that excludes
  // r is harmless anyway: its edge's projection misses L' and is clipped away.
  st.valid.clear();
  if (ls.edge_tree) {
    for (const uint32_t cand : st.edge_candidates) {
      const uint32_t ei = cand & EdgeTree::kEdgeMask;
      const Edge& edge = sc.edges[ei];
      // wedge_edge depends on the edge and the light only: memoised per thread and light.
      uint8_t& known = st.wedge_memo->known[ei];
      if (known >> 1 != st.wedge_tag)
        known = uint8_t(st.wedge_tag << 1 | (wedge_edge(sc, st.integrator, ls.frame, edge) ? 1 : 0));
      if (!(known & 1)) continue;
      // The weight the leaf test proved, or the double test's.
      const int weight = cand & EdgeTree::kWeightPlus2    ? 2
                         : cand & EdgeTree::kWeightMinus2 ? -2
                                                          : st.integrator.edge_weight(edge);
      if (weight != 0) st.valid.emplace_back(ei, weight);
    }
  }
  for (const WedgeState& ws : st.candidates) {
    const Wedge& w = ls.wedges[ws.wedge];
    if (!point_in_wedge(w, ws.mask, r, sc.eps)) continue;
    int weight = st.integrator.edge_weight(sc.edges[w.edge]);
    if (weight != 0) st.valid.emplace_back(w.edge, weight);
  }
  auto d = Clock::now();
  st.integrator.expect_edges(st.valid.size() + ls.cut_triangles.size());
  for (const auto& [edge, weight] : st.valid) st.integrator.add_edge(sc.edges[edge], weight);
  for (uint32_t t : ls.cut_triangles) st.integrator.add_cut(t);
  st.classes = st.integrator.finish_classes(st.depth, kUnclear);
  auto e = Clock::now();
  st.c.queries += 1;
  st.c.reported += double(ls.edge_tree ? st.edge_candidates.size() : st.candidates.size());
  st.c.validated += double(st.valid.size());
  st.c.t_query += seconds_between(a, b);
  st.c.t_integrate += seconds_between(b, c) + seconds_between(d, e);
  st.c.t_valid += seconds_between(c, d);
  return true;
}

// The receiver's bits from its depth complexities: reference ray to the minimum class
// and check ray to the classes above it (see "Reference rays" above). When the
// integration was doubtful, no reference is conclusive, or the check finds a class
// above the minimum unblocked (the counters are inconsistent), the receiver is answered
// by one ray per sample. Unclear samples (within the margin of a projected piece,
// DepthCounter::finish) take no part in the classes: their depth becomes kUnclear and
// each gets its own ray.
void answer_receiver(ThreadState& st, const SceneSetup& sc, const LightSetup& ls, size_t i, ReceiverResult& rr) {
  const Vec3f& r = sc.scene.receivers[i].p;
  const int samples = ls.light.samples;
  // Lowest and second-lowest class; st.depth holds kUnclear for unclear samples
  // (DepthCounter::finish_classes).
  const int32_t dmin = st.classes.dmin, second = st.classes.second;
  size_t unclear = st.classes.unclear;
  const bool one_class = second == kUnclear;
  RefAnswer ref = RefAnswer::Ambiguous, check = RefAnswer::Blocked;
  if (dmin == kUnclear && !st.integrator.doubtful()) {
    ref = RefAnswer::Blocked;  // no clear sample: every one gets its own ray below
  } else if (!st.integrator.doubtful()) {
    const RefContext ctx{sc.embree, ls.light, ls.frame, st.integrator, st.depth, r, i, ls.index};
    ref = class_answer(ctx, dmin, st.expect_blocked, st.c.rays);
    const bool decided = ref == RefAnswer::Visible || ref == RefAnswer::Blocked;
    if (decided) st.expect_blocked = ref == RefAnswer::Blocked;
    if (decided && !one_class) check = check_answer(ctx, dmin, second, st.c.rays);
    if (check == RefAnswer::NoCandidate) {
      st.c.unchecked += 1;
      check = RefAnswer::Blocked;
    }
  }
  const bool decided = ref == RefAnswer::Visible || ref == RefAnswer::Blocked;
  if (!decided || check == RefAnswer::Ambiguous) st.c.doubtful += 1;
  else if (check == RefAnswer::Visible) st.c.inconsistent += 1;
  if (!decided || check != RefAnswer::Blocked) {
    cast_all(sc, ls, i, rr);
    st.c.fallback += samples;
    unclear = 0;
  } else if (ref == RefAnswer::Visible) {
    set_class_bits(rr, ls.offset, samples, st.depth, dmin);
  }
  if (unclear > 0) {
    for (int j = 0; j < samples; ++j)
      if (st.depth[size_t(j)] == kUnclear)
        rr.set_visible(ls.offset + size_t(j), !sc.embree.occluded(r, sample_position(ls.light, j, i)));
    st.c.unclear_rays += double(unclear);
  }
}

// One receiver of one light.
void solve_receiver(ThreadState& st, const SceneSetup& sc, const LightSetup& ls, size_t i, uint32_t pos,
                    SolveResult& result) {
  ReceiverResult& rr = result.receivers[i];
  if (ls.occluded[i]) return;  // every sample blocked: the bits stay cleared
  if (ls.light_fallback || grazing_receiver(ls.frame, sc.scene.receivers[i].p)) {
    auto a = Clock::now();
    cast_all(sc, ls, i, rr);
    st.c.fallback += ls.light.samples;
    st.c.t_ray += seconds_between(a, Clock::now());
    return;
  }
  if (ls.all_rays || !integrate_receiver(st, sc, ls, i, pos)) {
    auto a = Clock::now();
    cast_fan(st, sc, ls, i, rr);
    st.c.fallback += ls.light.samples;
    st.c.edge_rays += 1;
    st.c.t_ray += seconds_between(a, Clock::now());
    return;
  }
  auto e = Clock::now();
  answer_receiver(st, sc, ls, i, rr);
  st.c.t_ray += seconds_between(e, Clock::now());
}

// edge_rays: a receiver and light with more than kEdgeRayLimit candidate edges per sample,
// and more than kMinRayCandidates, is answered by one ray per sample. Callgrind on
// foliage (1,024 x 64): an integrated edge costs about 500 instructions with its share
// of the walk and validation, a verified packet ray about 1,300, so past a few edges per
// sample the rays are cheaper; limits 1 / 2 / 3 / 4 / 6 gave 133.5M / 147.2M / 160.4M /
// 175.4M / 202.5M (the capped walk grows with the limit). Below 64 candidates the
// integration costs less than about 25 rays plus the walk and references a receiver
// pays anyway: few samples never cast. Returns the limit in candidates.
constexpr long kEdgeRayLimit = 1;
constexpr int64_t kMinRayCandidates = 64;
uint32_t ray_limit(long per_sample, int samples) {
  return uint32_t(std::clamp<int64_t>(int64_t(per_sample) * samples, kMinRayCandidates, int64_t(1) << 31));
}

// ray_solve=auto: a solve whose probe (below) finds at least kRaySolveDen / kRaySolveNum
// (a half) of its receivers past the ray limit answers every receiver by its rays and
// builds no index: there the capped walks of the cast receivers and the index's build
// cost more than the rays of the receivers below the limit (measured from 59% past on
// foliage, armadillo and bunny; a scene with none past, rooms, pays more by rays, hence
// the probe: docs/log/ssv-performance.md, nineteenth round).
constexpr size_t kRaySolveNum = 2, kRaySolveDen = 1;

// wedge_index=auto picks the edge hierarchy from this many mesh edges per receiver.
constexpr double kEdgesPerReceiver = 16.0;

// edge_rays' probe, a cost estimate before any index is built: how many of up to kProbes
// receivers spread over the scene (receiver order, the lights in turn) have more edges
// of nonzero weight inside their frustum to L' (EdgeFrustum, double) than the ray limit,
// counted over every k-th edge and scaled by k, where k is a quarter of the smallest
// limit (a receiver is past it on at least 4 counted edges). It only chooses the index,
// never an answer.
constexpr size_t kProbes = 12;
struct ProbeCounts {
  size_t probes = 0, past = 0;
};
// The receivers both probes test, and their counts: up to kProbes spread over the scene
// (receiver order, the lights in turn: the usable ones `take_light` accepts), none
// grazing; past_limit(frame, light, r) says whether r is past the ray limit. Stops once
// `max_below` are below it.
template <class TakeLight, class PastLimit>
ProbeCounts probe_receivers(const Scene& scene, size_t max_below, TakeLight&& take_light, PastLimit&& past_limit) {
  const size_t per_light = std::max<size_t>(2, kProbes / scene.lights.size());
  const size_t step = std::max<size_t>(1, scene.receivers.size() / per_light);
  ProbeCounts pc;
  auto more = [&] { return pc.probes < kProbes && pc.probes - pc.past < max_below; };
  for (size_t l = 0; l < scene.lights.size() && more(); ++l) {
    const LightFrame frame = make_light_frame(scene.lights[l]);
    if (!frame.usable || !take_light(frame)) continue;
    for (size_t i = step / 2; i < scene.receivers.size() && more(); i += step) {
      const Vec3f& r = scene.receivers[i].p;
      if (grazing_receiver(frame, r)) continue;
      pc.past += past_limit(frame, l, r) ? 1 : 0;
      ++pc.probes;
    }
  }
  return pc;
}
ProbeCounts probe_past_limit(const mesh::PreparedMesh& pm, const std::vector<Edge>& edges, const Scene& scene,
                             long per_sample) {
  if (edges.empty() || scene.receivers.empty() || scene.lights.empty()) return {};
  uint32_t min_cap = std::numeric_limits<uint32_t>::max();
  for (const Light& light : scene.lights) min_cap = std::min(min_cap, ray_limit(per_sample, light.samples));
  const size_t stride = std::max<size_t>(1, min_cap / 4);
  // The sampled edges' triangles' normals (unnormalised: only signs are read).
  struct Probe {
    Vec3d a, b, n1, n2;
    bool single;
  };
  std::vector<Probe> sampled;
  auto normal = [&](int32_t t) {
    const auto& v = pm.triangles[size_t(t)].v;
    const Vec3d p = to_double(pm.vertex_pos[v[0]]);
    return cross(to_double(pm.vertex_pos[v[1]]) - p, to_double(pm.vertex_pos[v[2]]) - p);
  };
  for (size_t e = 0; e < edges.size(); e += stride) {
    const Edge& ed = edges[e];
    const bool single = ed.t1 < 0 || ed.t2 < 0;
    sampled.push_back({to_double(pm.vertex_pos[ed.a]), to_double(pm.vertex_pos[ed.b]), single ? Vec3d(0, 0, 0) : normal(ed.t1),
                       single ? Vec3d(0, 0, 0) : normal(ed.t2), single});
  }
  return probe_receivers(
      scene, kProbes, [](const LightFrame&) { return true; },
      [&](const LightFrame& frame, size_t l, const Vec3f& rf) {
        const size_t cap = ray_limit(per_sample, scene.lights[l].samples) / stride;  // in counted edges
        const EdgeFrustum f(frame, rf);
        const Vec3d r = to_double(rf);
        size_t in = 0;
        for (size_t k = 0; k < sampled.size() && in <= cap; ++k) {
          const Probe& p = sampled[k];
          bool outside = false;
          for (int q = 0; q < f.count && !outside; ++q)
            outside = dot(f.n[q], p.a) < f.d[q] && dot(f.n[q], p.b) < f.d[q];
          if (outside) continue;
          if (p.single || (dot(p.n1, r - p.a) > 0.0) != (dot(p.n2, r - p.a) > 0.0)) ++in;
        }
        return in > cap;
      });
}

// The edge tree's frontier per batch of at most kEdgeBatch receivers: nodes of at most
// kFrontierEdges edges (measured on scan 75k: batches of 8 beat 4 and 32, frontiers of
// 64 edges beat 16 and 128, by callgrind instructions).
constexpr uint32_t kFrontierEdges = 64, kEdgeBatch = 8;

// ray_solve's probe on meshes of at least kEdgesPerReceiver edges per receiver, which
// build the edge tree anyway: the capped walk (the solver's own test) of probe_receivers'
// receivers on lights of flat jitter, from the root, stopping once `max_below` are below
// the limit (cheaper there than the sampled count: docs/log/ssv-performance.md, nineteenth
// round). It only chooses, never an answer.
ProbeCounts tree_probe(const EdgeTree& tree, const Scene& scene, float eps, long per_sample, size_t max_below) {
  if (tree.empty() || scene.receivers.empty() || scene.lights.empty()) return {};
  std::vector<uint32_t> starts, out;
  return probe_receivers(
      scene, max_below, [](const LightFrame& frame) { return !(double(frame.max_jitter_h) > 1e-5 * frame.extent); },
      [&](const LightFrame& frame, size_t l, const Vec3f& r) {
        const uint32_t cap = ray_limit(per_sample, scene.lights[l].samples);
        const EdgeFrustum f(frame, r);
        tree.frontier(f, frame, eps, std::numeric_limits<uint32_t>::max(), starts);  // the root
        tree.query(f, frame, eps, starts, out, cap);
        return out.size() > cap;
      });
}

// The frontier's node size for `edges` mesh edges and `receivers` receivers: the largest
// power of two not above the edges per receiver, at least kFrontierEdges. A denser mesh
// puts more nodes of a given size in one batch's frustum, and the frontier walk visits
// them all while each receiver's walk below them is about as long (scan 300k, 439 edges
// per receiver: 64 / 128 / 256 / 512 / 1,024 gave `solve_scene` 930.3M / 925.3M / 923.8M
// / 924.2M / 925.5M; 75k, 110 per receiver: 64 / 128 / 256 gave 357.8M / 358.5M /
// 359.7M). Only where the receivers' walks start changes: from any frontier they return
// every edge that may count (edge_tree.h; the same candidate lists on the scenes measured).
uint32_t frontier_edges(size_t edges, size_t receivers) {
  uint32_t f = kFrontierEdges;
  while (f < (1u << 30) && double(2 * uint64_t(f)) <= double(edges) / double(std::max<size_t>(receivers, 1))) f *= 2;
  return f;
}

// Every receiver of one light (paper 001 section 2.1), in parallel. With the scattered
// candidates, batch by batch of the receiver tree (the scatter of a batch is serial);
// returns the scatter's seconds.
double solve_light(const SceneSetup& sc, const LightSetup& ls, tbb::enumerable_thread_specific<ThreadState>& states,
                   SolveResult& result, const std::vector<int32_t>& batches, float eps, bool use_region,
                   MemoryCharge& charge) {
  if (ls.all_rays) {
    const tbb::blocked_range<size_t> all(0, sc.scene.receivers.size(), 8);
    tbb::parallel_for(all, [&](const tbb::blocked_range<size_t>& range) {
      const IeeeFloatMode range_float_mode;
      ThreadState& st = states.local();
      for (size_t i = range.begin(); i != range.end(); ++i) solve_receiver(st, sc, ls, i, 0, result);
    });
    return 0.0;
  }
  if (ls.edge_tree) {
    // Batch by batch of the receiver tree: the walk down to the frontier of the batch's
    // receivers is shared by their queries (edge_tree.h).
    const auto& ord = ls.tree.order();
    const uint32_t frontier = frontier_edges(sc.edges.size(), sc.scene.receivers.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, batches.size(), 1), [&](const tbb::blocked_range<size_t>& range) {
      const IeeeFloatMode range_float_mode;
      ThreadState& st = states.local();
      for (size_t k = range.begin(); k != range.end(); ++k) {
        const auto& nd = ls.tree.nodes()[size_t(batches[k])];
        AABBd box;
        for (uint32_t p = nd.begin; p < nd.end; ++p)
          if (!ls.occluded[ord[p]]) box.extend(to_double(sc.scene.receivers[ord[p]].p));
        if (box.empty()) continue;  // every receiver occluded: nothing to answer
        auto a = Clock::now();
        ls.edge_tree->frontier(EdgeFrustum(ls.frame, box), ls.frame, sc.eps, frontier, st.edge_starts);
        // The candidates of every receiver solve_receiver will integrate, in one walk
        // (the same lists as one query each).
        st.batch_frusta.clear();
        st.batch_receivers.clear();
        for (uint32_t p = nd.begin; p < nd.end; ++p) {
          const size_t i = ord[p];
          const Vec3f& r = sc.scene.receivers[i].p;
          if (ls.occluded[i] || ls.light_fallback || grazing_receiver(ls.frame, r)) continue;
          st.batch_frusta.emplace_back(ls.frame, r);
          st.batch_receivers.push_back(i);
        }
        if (st.batch_lists.size() < st.batch_frusta.size()) st.batch_lists.resize(st.batch_frusta.size());
        ls.edge_tree->query_batch(st.batch_frusta.data(), st.batch_frusta.size(), ls.frame, sc.eps, st.edge_starts,
                                  st.batch_lists.data(), ls.ray_limit);
        st.c.t_query += seconds_between(a, Clock::now());
        size_t next = 0;
        for (uint32_t p = nd.begin; p < nd.end; ++p) {
          const bool listed = next < st.batch_receivers.size() && st.batch_receivers[next] == ord[p];
          st.batched = listed ? &st.batch_lists[next++] : nullptr;
          solve_receiver(st, sc, ls, ord[p], p, result);
        }
        st.batched = nullptr;
      }
    });
    return 0.0;
  }
  if (ls.bsp) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, sc.scene.receivers.size(), 8),
                      [&](const tbb::blocked_range<size_t>& range) {
                        const IeeeFloatMode range_float_mode;
                        ThreadState& st = states.local();
                        for (size_t i = range.begin(); i != range.end(); ++i) solve_receiver(st, sc, ls, i, 0, result);
                      });
    return 0.0;
  }
  double scatter_seconds = 0.0;
  const auto& ord = ls.tree.order();
  std::vector<std::vector<uint32_t>> passed;  // the batch nodes' own tests, a group at a time
  for (size_t bi = 0; bi < batches.size(); ++bi) {
    const int32_t b = batches[bi];
    const auto& nd = ls.tree.nodes()[size_t(b)];
    auto t0 = Clock::now();
    const size_t group = bi % WedgeScatter::kPassGroup;
    if (group == 0) ls.scatter->pass_batches(ls.tree, batches, bi, ls.wedges, eps, use_region, passed);
    ls.scatter->build(ls.tree, b, ls.wedges, eps, use_region, ls.occluded, &passed[group]);
    charge.set(ls.scatter->memory_bytes());
    scatter_seconds += seconds_between(t0, Clock::now());
    tbb::parallel_for(tbb::blocked_range<uint32_t>(nd.begin, nd.end, 8), [&](const tbb::blocked_range<uint32_t>& range) {
      const IeeeFloatMode range_float_mode;
      ThreadState& st = states.local();
      for (uint32_t p = range.begin(); p != range.end(); ++p) solve_receiver(st, sc, ls, ord[p], p, result);
    });
  }
  return scatter_seconds;
}

// The stats of paper 001's Tables 2-4 and the fallback counters (docs/methods/ssv.md).
void write_stats(Stats& s, const Counts& n, const WedgeBuildCounts& counts, double nodes) {
  const std::pair<const char*, double> values[] = {
      {"edges", double(counts.edges)},
      {"edges_below_light", double(counts.below_light)},
      {"edges_never_silhouette", double(counts.not_silhouette)},
      {"edges_outside_regions", double(counts.region_culled)},
      {"wedges", double(counts.wedges)},
      {"wedge_planes_dropped", double(counts.planes_dropped)},
      {"bsp_nodes", nodes},
      {"queries", n.queries},
      {"wedges_reported", n.queries > 0 ? n.reported / n.queries : 0.0},
      {"wedges_validated", n.queries > 0 ? n.validated / n.queries : 0.0},
      {"acceptance_ratio", n.reported > 0 ? n.validated / n.reported : 0.0},
      {"reference_rays", n.rays},
      {"fallback_relations", n.fallback},
      {"inconsistent_receivers", n.inconsistent},
      {"doubtful_receivers", n.doubtful},
      {"unchecked_receivers", n.unchecked},
      {"unclear_relations", n.unclear_rays},
      {"edge_ray_receivers", n.edge_rays},
      {"packet_undecided", n.packet_undecided},
  };
  for (const auto& [key, value] : values) s.set(key, value);
}

// Shaft culling. The edges whose boxes meet the box of hull(unit, L') for some shaft unit
// (a receiver-tree node of at most 32 receivers) with a receiver not occluded, ascending.
// Any other edge meets no segment from such a receiver to L': its projection from each of
// them misses L', so it adds nothing (integrate.h) and is given no wedge. The boxes are
// rounded outwards to float and grown by `grow`. One traversal of the edge BVH with the
// list of shaft boxes meeting each node: a node inside some shaft box has every edge
// below it marked without further tests.
struct ShaftMarker {
  const accel::Bvh<float>& bvh;
  std::vector<AABB> shafts;
  std::vector<uint8_t>& mark;

  void mark_all(uint32_t i) {
    const auto& nd = bvh.node(i);
    if (bvh.is_leaf(nd)) {
      for (uint32_t e : bvh.leaf_items(nd)) mark[e] = 1;
      return;
    }
    mark_all(bvh.left(i));
    mark_all(bvh.right(i));
  }
  void walk(uint32_t i, const std::vector<uint32_t>& cand) {
    const auto& nd = bvh.node(i);
    std::vector<uint32_t> sub;
    for (uint32_t c : cand) {
      const AABB& q = shafts[c];
      if (!q.overlaps(nd.box)) continue;
      if (q.contains(nd.box.lo) && q.contains(nd.box.hi)) {
        mark_all(i);
        return;
      }
      sub.push_back(c);
    }
    if (sub.empty()) return;
    if (bvh.is_leaf(nd)) {
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k)
        for (uint32_t c : sub)
          if (shafts[c].overlaps(bvh.item_box(k))) {
            mark[bvh.item(k)] = 1;
            break;
          }
      return;
    }
    walk(bvh.left(i), sub);
    walk(bvh.right(i), sub);
  }
};

void shaft_edges(const ReceiverTree& tree, const std::vector<uint8_t>& occluded, const accel::Bvh<float>& bvh,
                 const std::vector<Vec3d>& light, float grow, std::vector<uint8_t>& mark, std::vector<uint32_t>& out) {
  mark.assign(bvh.item_count(), 0);
  AABBd lb;
  for (const Vec3d& p : light) lb.extend(p);
  ShaftMarker sm{bvh, {}, mark};
  // Shaft units of 32 receivers: a leaf's shaft box is tighter, but one BVH walk per leaf
  // cost more than the wedges it saved on columns.
  const auto& ord = tree.order();
  for (int32_t id : WedgeScatter::batches(tree, 32)) {
    const ReceiverTree::Node& nd = tree.nodes()[size_t(id)];
    bool open = false;
    for (uint32_t p = nd.begin; p < nd.end && !open; ++p) open = !occluded[ord[p]];
    if (!open) continue;
    AABBd b = nd.box;
    b.extend(lb);
    AABB q;
    for (int k = 0; k < 3; ++k) {
      q.lo[k] = std::nextafter(float(b.lo[k]), -INFINITY) - grow;
      q.hi[k] = std::nextafter(float(b.hi[k]), INFINITY) + grow;
    }
    sm.shafts.push_back(q);
  }
  std::vector<uint32_t> all(sm.shafts.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = uint32_t(k);
  if (!all.empty() && !bvh.empty()) sm.walk(0, all);
  out.clear();
  for (size_t e = 0; e < mark.size(); ++e)
    if (mark[e]) out.push_back(uint32_t(e));
}

// The culling structures of a solve (docs/methods/ssv.md, "Culling"): the receiver tree
// (leaves of 4), the planar occluders (the 1024 largest, none below a quarter of the
// smallest light), the edges' boxes in a BVH (shaft culling) and the shaft units (tree
// nodes of at most 32 receivers).
struct Culling {
  ReceiverTree tree;
  std::vector<PlanarOccluder> occluders;
  accel::Bvh<float> edge_bvh;
  EdgeTree edge_tree;  // wedge_index=edges
  std::vector<int32_t> units;
  Culling(const Scene& scene, const mesh::PreparedMesh& pm, const std::vector<Edge>& edges,
          PlaneSource planes, bool occluders_on, bool shafts_on, bool tree_on, bool edges_on,
          double M) {
    if (tree_on) {
      std::vector<Vec3d> points(scene.receivers.size());
      for (size_t i = 0; i < points.size(); ++i) points[i] = to_double(scene.receivers[i].p);
      tree = ReceiverTree(points, 4);
      units = WedgeScatter::batches(tree, 32);
    }
    // The edge tree first: it finds the occluder candidates without a pass over every
    // triangle.
    if (edges_on) edge_tree = EdgeTree(edges, pm, M);
    if (occluders_on) {
      double min_light = INFINITY;
      for (const Light& lt : scene.lights) {
        Vec3d sum(0, 0, 0);  // twice the polygon's vector area, fanned from its first vertex
        for (size_t k = 1; k + 1 < lt.polygon.size(); ++k)
          sum = sum + cross(to_double(lt.polygon[k]) - to_double(lt.polygon[0]),
                            to_double(lt.polygon[k + 1]) - to_double(lt.polygon[0]));
        min_light = std::min(min_light, 0.5 * length(sum));
      }
      const double min_area = std::isfinite(min_light) ? 0.25 * min_light : 0.0;
      std::vector<uint32_t> large;
      const bool by_tree = edges_on && min_area > 0.0;
      if (by_tree) edge_tree.large_triangle_edges(min_area * min_area, large);
      occluders = planar_occluders(pm, edges, planes, 1024, min_area, by_tree ? &large : nullptr);
    }
    if (shafts_on) {
      std::vector<AABB> boxes(edges.size());
      for (size_t e = 0; e < edges.size(); ++e) boxes[e] = AABB(pm.vertex_pos[edges[e].a], pm.vertex_pos[edges[e].b]);
      edge_bvh = accel::Bvh<float>(boxes, accel::BuildRule{accel::Split::MortonHalves, 4, true});
    }
  }
  double memory_bytes() const {
    return double(occluders.capacity() * sizeof(PlanarOccluder) + tree.memory_bytes() + edge_bvh.memory_bytes() +
                  edge_tree.memory_bytes());
  }
};

// The light points of the occluder test: L' at the largest jitter height on both sides of
// its plane, whose hull holds every sample (light_frame.h).
std::vector<Vec3d> light_points(const LightFrame& frame) {
  std::vector<Vec3d> lp;
  const double jh = double(frame.max_jitter_h);
  for (const Vec3d& p : frame.poly_world) {
    lp.push_back(p + frame.N * jh);
    if (jh > 0.0) lp.push_back(p - frame.N * jh);
  }
  return lp;
}

// The bounds of the receivers left (not occluded) of each shaft unit, for build_wedges'
// silhouette-region test. Used with the scattered index only: it hands out exactly the
// wedges whose region these boxes do not all exclude.
RegionBoxes region_boxes(const Scene& scene, const ReceiverTree& tree, const std::vector<int32_t>& units,
                         const std::vector<uint8_t>& occluded, float eps) {
  RegionBoxes regions;
  regions.eps = eps;
  const auto& ord = tree.order();
  for (int32_t id : units) {
    const ReceiverTree::Node& nd = tree.nodes()[size_t(id)];
    AABB b;
    for (uint32_t p = nd.begin; p < nd.end; ++p)
      if (!occluded[ord[p]]) b.extend(scene.receivers[ord[p]].p);
    if (b.empty()) continue;
    regions.parts.push_back(b);
    regions.all.extend(b);
  }
  return regions;
}

}  // namespace

// Over 150 lines: the per-light loop shares the solve's tolerances, memory charges, reused
// buffers and counters; the culling steps it calls are functions above.
SolveResult SsvSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  const IeeeFloatMode float_mode;
  const bool use_region = opt.get_bool("silhouette_regions", true);
  const bool use_occluders = opt.get_bool("occluder_culling", true);
  const bool use_shafts = opt.get_bool("shaft_culling", true);
  std::string index = opt.get("wedge_index", "auto");
  const bool edge_rays = opt.get_bool("edge_rays", true);
  const long edge_ray_limit = std::max(0L, opt.get_int("edge_ray_limit", kEdgeRayLimit));
  const std::string ray_solve = opt.get("ray_solve", "auto");
  const bool packet_rays = opt.get_bool("packet_rays", true);

  auto tp0 = Clock::now();
  size_t slivers = 0;
  const std::optional<TriangleSoup> kept = without_slivers(scene.mesh, slivers);
  const TriangleSoup& blockers = kept ? *kept : scene.mesh;
  const mesh::PreparedMesh pm = mesh::prepare_mesh(blockers);
  auto t0 = Clock::now();

  SolveResult result = make_empty_result(scene);
  const std::vector<Edge> edges = mesh_edges(pm);
  // Root box. Paper 001 (section 4.1) roots the BSP at the scene bounds, assuming every
  // query lies inside. Here every query point is known in advance: the receivers. The
  // root is their bounds (grown by 1e-3 of the scene's diagonal, so each lies strictly
  // inside): the lazy construction never refines outside it anyway, but the top levels
  // of a scene-sized root classify every wedge of the light, most of which never reach
  // a receiver (rooms: 27 lights on several storeys over a grid of receivers on the
  // ground floor). The minimum node size stays 1/200 of the scene's longest side.
  const AABB scene_box = scene_bounds(scene, pm, !kept);
  const float grow = float(1e-3 * scene_box.diagonal()) + std::numeric_limits<float>::min();
  const float min_node = max_component(scene_box.extent()) / 200.0f;
  // Tolerances. M bounds the magnitude of every coordinate. A float plane test n.x - d
  // with a unit normal errs by a few ulps of M (about 4e-7 M with the rounding of n and d
  // from double); eps = 4e-6 M is ten times that. `tol` judges the double-precision
  // wedge planes (errors about 1e-15 M).
  const double M = std::max(max_component(vabs(scene_box.lo)), max_component(vabs(scene_box.hi))) + double(grow);
  const float eps = float(4e-6 * M);
  const double tol = 1e-9 * M;
  // wedge_index=auto: the edge hierarchy where the mesh has at least kEdgesPerReceiver
  // edges per receiver (a dense mesh: the wedges' per-light work grows with its edges,
  // a walk per receiver only with their logarithm), the scattered wedges otherwise
  // (few edges, many receivers: one walk per wedge and batch is cheaper than one per
  // receiver). Measured by callgrind instructions: scan 75k (110 edges per receiver)
  // 1,383M -> 593M with the edges, rooms (38) equal, foliage (12) +12% and columns
  // (0.9) 2.8x with them. Answers do not depend on the choice.
  // Noisy scanned surfaces (silhouettes everywhere) take the edges too: the leaves' per-edge
  // facing test hands out about the edges that validate (CGAL's bunny, armadillo and
  // elephant: 153, 505 and 268 per receiver), where the wedges build and scatter a third
  // of the mesh's edges per light (docs/log/ssv-performance.md, ninth round).
  // With edge_rays, a mesh below that density still takes the edges when the probe finds
  // most receivers past the ray limit (foliage: every leaf above every receiver): their
  // walks stop at the limit, where the wedges would be built and scattered in full; with
  // ray_solve (kRaySolveNum) no index at all then: rays for every receiver.
  bool rays_chosen = false, rays_only = false;
  const bool auto_index = index == "auto";
  const bool sparse = double(edges.size()) < kEdgesPerReceiver * double(scene.receivers.size());
  if (auto_index && sparse && edge_rays) {
    const ProbeCounts pc = probe_past_limit(pm, edges, scene, edge_ray_limit);
    if (pc.probes > 0 && 2 * pc.past >= pc.probes) {
      index = "edges";
      rays_chosen = true;
      rays_only = ray_solve == "auto" && kRaySolveNum * pc.past >= kRaySolveDen * pc.probes;
    }
  }
  if (index == "auto") index = double(edges.size()) >= kEdgesPerReceiver * double(scene.receivers.size()) ? "edges" : "receivers";
  // The edge index marks proven weights in its candidates' top bits (edge_tree.h): a mesh
  // of more edges than those leave (2^30, far beyond any memory budget) takes the wedges.
  bool use_edges = !rays_only && index == "edges" && edges.size() <= size_t(EdgeTree::kEdgeMask);
  const bool use_scatter = !rays_only && (index == "receivers" || (index == "edges" && !use_edges));
  // The triangle planes as an array for the wedge indexes (build_wedges reads every
  // edge's per light); the edge index reads only its candidates' and computes them.
  TrianglePlanes tri_planes;
  if (!use_edges && !rays_only) tri_planes = triangle_planes(pm);
  PlaneSource planes{&pm, use_edges || rays_only ? nullptr : &tri_planes};

  std::vector<Vec3d> frame_pos;  // per light, its capacity reused

  auto tc0 = Clock::now();
  Culling cull(scene, pm, edges, planes, use_occluders, use_shafts && !use_edges && !rays_only,
               use_occluders || use_shafts || use_scatter || use_edges, use_edges, M);
  // ray_solve on a dense mesh (the edges by density): the edge tree's probe.
  if (auto_index && !sparse && use_edges && edge_rays && ray_solve == "auto") {
    // Past max_below receivers below the limit, kRaySolveDen / kRaySolveNum of kProbes
    // are out of reach.
    const size_t max_below = kProbes - (kRaySolveDen * kProbes + kRaySolveNum - 1) / kRaySolveNum + 1;
    const ProbeCounts pc = tree_probe(cull.edge_tree, scene, eps, edge_ray_limit, max_below);
    if (pc.probes > 0 && kRaySolveNum * pc.past >= kRaySolveDen * pc.probes) {
      rays_only = rays_chosen = true;
      use_edges = false;
    }
  }
  double cull_seconds = seconds_between(tc0, Clock::now()), culled_relations = 0, hidden_lights = 0;
  // embree_quads=auto: paired quads where the mesh has at least one triangle per receiver
  // and light. The build is linear in the triangles, the rays about one per receiver and
  // light, and a quad leaf tests twice the triangles a ray meets (callgrind, whole solve:
  // scan 75k and 300k, 7 and 29 triangles per receiver and light, -3.8% and -5.5%; CGAL's
  // bunny, 74, -1.1%; rooms, 0.24, -0.1%; columns, 0.6 at 4,096 receivers, +0.6%).
  const std::string quads = opt.get("embree_quads", "auto");
  // A solve the probe sent to the edges for their rays (above) or to ray_solve casts
  // about one ray per relation instead: triangles trace them faster (foliage, callgrind:
  // the rays 84.3M -> 77.9M instructions as triangles).
  const bool use_quads = quads == "on" || (quads == "auto" && !rays_chosen &&
                                           double(blockers.size()) >= double(scene.receivers.size()) *
                                                                           double(scene.lights.size()));
  const auto tb0 = Clock::now();
  Caster embree(blockers, use_quads);
  // packet_rays: the receivers answered by their rays where the sampled probe of a
  // sparse mesh chose rays (foliage, callgrind, whole solve: 95.4M -> 68.9M). Not on
  // dense meshes, whose rays Embree traces in fewer instructions than the packets' walk
  // of many small leaves, after a build that costs more (CGAL's armadillo, 52k
  // triangles: 140.4M -> 211.5M with the packets).
  std::optional<PacketCaster> packets;
  if (packet_rays && rays_chosen && sparse) packets.emplace(blockers, float(M));
  const double embree_seconds = seconds_between(tb0, Clock::now());
  const SceneSetup sc{scene, embree, edges, eps, pm, tol, packets && packets->usable() ? &*packets : nullptr};
  const ReceiverTree& receiver_tree = cull.tree;
  const double occluder_bytes = cull.memory_bytes();
  const double occluder_margin = 1e-5 * M;

  double init_seconds = 0, peak_memory = 0, nodes = 0;
  // Per-light arrays, their capacity reused from light to light.
  std::vector<Wedge> wedges;
  std::vector<uint8_t> edge_mark;
  std::vector<uint32_t> edge_subset;
  std::vector<uint32_t> crossing;  // wedge_index=edges: candidates of light_plane_cuts
  double edges_outside = 0;
  MemoryBudget budget("ssv", opt.memory_budget_mb);
  // The scattered candidates, batch by batch of at most 256 receivers: their entries
  // (about the wedges reported per query times the batch) stay in cache; batches of
  // 16,384 made foliage's 5M entries three times slower than the BSP's queries.
  WedgeScatter scatter;
  const std::vector<int32_t> batches = use_scatter ? WedgeScatter::batches(receiver_tree, 256)
                                       : use_edges  ? WedgeScatter::batches(receiver_tree, kEdgeBatch)
                                                    : std::vector<int32_t>{};
  MemoryCharge scatter_charge;
  scatter_charge.bind(&budget, "scattered wedges");
  MemoryCharge occluder_charge;
  occluder_charge.bind(&budget, "occluders");
  occluder_charge.set(size_t(occluder_bytes));
  WedgeBuildCounts counts;
  Counts total;
  tbb::enumerable_thread_specific<WedgeMemo> wedge_memos;

  for (size_t l = 0; l < scene.lights.size(); ++l) {
    const Light& light = scene.lights[l];
    auto ti0 = Clock::now();
    const LightFrame frame = make_light_frame(light);
    // Samples off the light plane by more than 1e-5 of the light's extent, or far outside
    // the light polygon (explicit samples placed elsewhere, light_frame.h), break the
    // projection model: cast rays for that light.
    const bool light_fallback = double(frame.max_jitter_h) > 1e-5 * frame.extent || !frame.usable;
    // Receivers hidden from the light by one occluder. The light points: L' at the
    // largest jitter height on both sides of its plane, whose hull holds every sample.
    std::vector<uint8_t> occluded(scene.receivers.size(), 0);
    size_t n_occluded = 0;
    if (use_occluders && !light_fallback) {
      auto tc = Clock::now();
      const std::vector<Vec3d> lp = light_points(frame);
      n_occluded = cull_occluded_receivers(receiver_tree, cull.occluders, lp, occluder_margin, occluded);
      culled_relations += double(n_occluded) * double(light.samples);
      cull_seconds += seconds_between(tc, Clock::now());
    }
    const bool all_hidden = !scene.receivers.empty() && n_occluded == scene.receivers.size();
    hidden_lights += all_hidden ? 1.0 : 0.0;
    // The BSP's root: the bounds of the receivers left (see "Root box" above).
    AABB root;
    for (size_t i = 0; i < scene.receivers.size(); ++i)
      if (!occluded[i]) root.extend(scene.receivers[i].p);
    if (root.empty() && !scene.receivers.empty()) root = scene_box;
    root.lo -= Vec3f(grow, grow, grow);
    root.hi += Vec3f(grow, grow, grow);
    // The wedge indexes read most vertices' frame positions: an array. The edge index
    // computes those of its candidates on use, per thread (FramePositions).
    frame_pos.resize(all_hidden || use_edges || rays_only ? 0 : pm.vertex_pos.size());
    for (size_t v = 0; v < frame_pos.size(); ++v) frame_pos[v] = frame.to_local(pm.vertex_pos[v]);
    wedges.clear();
    std::vector<uint32_t> cut_triangles;
    if (!light_fallback && !all_hidden && use_edges) {
      cull.edge_tree.crossing_triangles(edges, frame, crossing);
      cut_triangles = light_plane_cuts(pm, FramePositions(pm.vertex_pos, frame), frame, crossing);
    } else if (!light_fallback && !all_hidden && !rays_only) {
      const bool subset = use_shafts && !cull.edge_bvh.empty();
      if (subset) {
        auto tc = Clock::now();
        shaft_edges(receiver_tree, occluded, cull.edge_bvh, frame.poly_world, float(eps), edge_mark, edge_subset);
        edges_outside += double(edges.size() - edge_subset.size());
        cull_seconds += seconds_between(tc, Clock::now());
      }
      // Silhouette regions against the receivers left, by shaft units (with the scattered
      // index only: it hands out exactly the wedges these boxes would not all exclude).
      const bool by_region = use_region && use_scatter;
      const RegionBoxes regions = by_region ? region_boxes(scene, receiver_tree, cull.units, occluded, eps) : RegionBoxes{};
      build_wedges(pm, edges, frame_pos, frame, tol, counts, planes.planes, wedges, subset ? &edge_subset : nullptr,
                   by_region ? &regions : nullptr);
      cut_triangles = light_plane_cuts(pm, frame_pos, frame);
    }
    MemoryCharge wedge_charge;
    wedge_charge.bind(&budget, "wedges");
    wedge_charge.set(wedges.capacity() * sizeof(Wedge));
    std::optional<WedgeBsp> bsp;
    if (!use_scatter && !use_edges && !rays_only) {
      bsp.emplace(wedges, root, min_node, eps, use_region);
      bsp->set_memory_budget(&budget);
    }
    const SampleStrips strips = make_sample_strips(frame.jitter_uv, light.samples, light.jitter);
    init_seconds += seconds_between(ti0, Clock::now());

    const LightSetup ls{light,         l,      scene.light_offset(l),
                        frame,         light_fallback, wedges,
                        cut_triangles, bsp ? &*bsp : nullptr, &scatter,
                        receiver_tree, strips, occluded, use_edges ? &cull.edge_tree : nullptr,
                        edge_rays ? ray_limit(edge_ray_limit, light.samples) : 0u, rays_only,
                        packets ? packet_order(frame, light) : std::vector<uint8_t>{}};
    tbb::enumerable_thread_specific<ThreadState> states([&] {
      ThreadState st(pm, planes, use_edges ? FramePositions(pm.vertex_pos, frame) : FramePositions(frame_pos), frame);
      if (use_edges) {
        // Built on the thread that asks for it: that thread's memo.
        st.wedge_memo = &wedge_memos.local();
        st.wedge_tag = st.wedge_memo->start(l, edges.size());
      }
      return st;
    });
    total.t_query += solve_light(sc, ls, states, result, batches, eps, use_region, scatter_charge);
    for (const ThreadState& st : states) total += st.c;
    nodes += bsp ? double(bsp->node_count()) : 0.0;
    double mem = (bsp ? double(bsp->memory_bytes()) : double(scatter.memory_bytes() + wedges.size() * sizeof(Wedge))) +
                 double(frame_pos.size() * sizeof(Vec3d)) +
                 double(edges.size() * sizeof(Edge)) + occluder_bytes;
    peak_memory = std::max(peak_memory, mem);
  }
  auto t2 = Clock::now();
  fractions_from_bits(scene, result);
  result.seconds = seconds_between(t0, t2);

  Stats& s = result.stats;
  const std::pair<const char*, double> times[] = {
      {"prepare_seconds", seconds_between(tp0, t0)}, {"embree_build_seconds", embree_seconds},
      {"init_seconds", init_seconds},                {"bsp_build_query_seconds", total.t_query},
      {"validation_seconds", total.t_valid},         {"projection_integration_seconds", total.t_integrate},
      {"reference_ray_seconds", total.t_ray},        {"relations", double(scene.relation_count())},
      {"ray_disputes", double(embree.disputes())},   {"slivers_dropped", double(slivers)},
      {"memory_mb", peak_memory / (1024.0 * 1024.0)}};
  for (const auto& [key, value] : times) s.set(key, value);
  write_stats(s, total, counts, nodes);
  const std::pair<const char*, double> culling_stats[] = {
      {"silhouette_regions", use_region ? 1.0 : 0.0},   {"occluder_culling", use_occluders ? 1.0 : 0.0},
      {"occluders", double(cull.occluders.size())},     {"occluded_relations", culled_relations},
      {"hidden_lights", hidden_lights},                 {"occluder_seconds", cull_seconds},
      {"shaft_culling", use_shafts ? 1.0 : 0.0},
      {"wedge_index_bsp", use_scatter || use_edges || rays_only ? 0.0 : 1.0},
      {"scattered_candidates", double(scatter.total_entries())}, {"edges_outside_shafts", edges_outside},
      {"edge_index", use_edges ? 1.0 : 0.0},            {"ray_solve", rays_only ? 1.0 : 0.0}};
  for (const auto& [key, value] : culling_stats) s.set(key, value);
  return result;
}

}  // namespace visgate::ssv
