// lib/ssv/integrate.h: the integration rule against direct counting.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <random>

#include "lib/mesh/prepare.h"
#include "lib/ssv/integrate.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/wedge.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

namespace {

// n samples of K jitter positions each in the light's [-1, 1]^2 frame: layout 0 a
// stratified grid moved by up to +-spread/2, 1 uniform, 2 all coincident, 3 a few points,
// 4 layout 0 with one jitter point of every fifth sample anywhere in v (tall boxes among
// short ones, as the fan-mapped strata of a polygon light give).
std::vector<Vec2f> jitter_layout(int layout, int n, int K, float spread, std::mt19937_64& g) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), u01(0.0f, 1.0f);
  const int side = std::max(1, int(std::sqrt(double(n))));
  std::vector<Vec2f> jitter(size_t(n) * size_t(K));
  for (size_t q = 0; q < jitter.size(); ++q) {
    const int j = int(q) / K;
    const float cu = -1.0f + 2.0f * (float(j % side) + 0.5f) / float(side);
    const float cv = -1.0f + 2.0f * (float(j / side) + 0.5f) / float(n / side + 1);
    if (layout == 0) jitter[q] = {cu + spread * (u01(g) - 0.5f), cv + spread * (u01(g) - 0.5f)};
    if (layout == 1) jitter[q] = {u(g), u(g)};
    if (layout == 2) jitter[q] = {0.25f, -0.5f};
    if (layout == 3) jitter[q] = {0.5f * float(q % 3), 0.25f * float(q % 2)};
    if (layout == 4)
      jitter[q] = {cu + spread * (u01(g) - 0.5f), j % 5 == 0 && int(q) % K == 0 ? u(g) : cv + spread * (u01(g) - 0.5f)};
  }
  return jitter;
}

}  // namespace

// ---------------------------------------------------------------- integration rule

TEST(SsvIntegration, StripCounterEqualsNaiveRule) {
  // The sub-linear counter against a plain loop over samples implementing rules 1 and 2.
  std::mt19937_64 g(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  // Above 512 samples in a piece's range the strips are used, below it the one-by-one test.
  for (int n : {1, 5, 16, 64, 256, 300, 1500, 4096}) {
    std::vector<Vec2f> uv(static_cast<size_t>(n));
    for (auto& p : uv) p = {u(g), u(g)};
    DepthCounter dc;
    dc.reset(uv, 2.0);
    std::vector<int32_t> naive(size_t(n), 0);
    for (int k = 0; k < 200; ++k) {
      Vec2f P{1.5f * u(g), 1.5f * u(g)}, Q{1.5f * u(g), 1.5f * u(g)};
      int w = int(g() % 5) - 2;
      dc.add_piece(P, Q, w);
      float vc = 1.2f * u(g);
      dc.add_step(vc, w);
      for (int j = 0; j < n; ++j) {
        const Vec2f& s = uv[size_t(j)];
        if (P.v != Q.v) {
          bool up = Q.v > P.v;
          Vec2f lo = up ? P : Q, hi = up ? Q : P;
          if (s.v >= lo.v && s.v < hi.v && cross2(Vec2f{hi.u - lo.u, hi.v - lo.v}, Vec2f{s.u - lo.u, s.v - lo.v}) > 0.0f)
            naive[size_t(j)] += up ? w : -w;
        }
        if (s.v >= vc) naive[size_t(j)] += w;
      }
    }
    std::vector<int32_t> got;
    dc.finish(got);
    EXPECT_EQ(got, naive) << "n = " << n;
  }
}

TEST(SsvIntegration, JitterBoxStripsEqualNaiveRule) {
  // The per-light strips over jitter boxes (K points per sample, one picked per receiver)
  // against the plain loop: small boxes (a stratified pattern), boxes as wide as the
  // light (a random pattern: everything is tested one by one) and K = 1, with pieces and
  // steps placed exactly on sample coordinates as well as at random.
  // Layout 4 mixes tall boxes with short ones (the v-ranges' first positions from the
  // prefix maxima of v_hi, not from the tallest box).
  std::mt19937_64 g(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int layout : {0, 4})
    for (int K : {1, 4, 16})
      for (float spread : {0.02f, 2.0f})
        for (int n : {1, 7, 64, 256, 2048}) {
          const std::vector<Vec2f> jitter = jitter_layout(layout, n, K, spread, g);
          const SampleStrips strips = make_sample_strips(jitter, n, K);
          for (int receiver = 0; receiver < 3; ++receiver) {
            std::vector<uint32_t> pick(static_cast<size_t>(n));
            std::vector<Vec2f> uv(static_cast<size_t>(n));
            for (int j = 0; j < n; ++j) {
              pick[size_t(j)] = uint32_t(j * K + int(g() % uint64_t(K)));
              uv[size_t(j)] = jitter[pick[size_t(j)]];
            }
            DepthCounter dc;
            dc.reset(strips, jitter, pick, 2.0);
            // Each sample's point is its picked jitter point (gathered with AVX2 when available).
            for (int j = 0; j < n; ++j) {
              EXPECT_EQ(dc.sample_uv(size_t(j)).u, uv[size_t(j)].u);
              EXPECT_EQ(dc.sample_uv(size_t(j)).v, uv[size_t(j)].v);
            }
            // Every other receiver in the picked points' own v order (at most 512 samples).
            EXPECT_EQ(receiver % 2 == 1 && dc.use_sorted_order(), receiver % 2 == 1 && n <= 512);
            std::vector<int32_t> naive(size_t(n), 0);
            std::vector<uint8_t> naive_unclear(size_t(n), 0);
            for (int k = 0; k < 150; ++k) {
              Vec2f P{1.5f * u(g), 1.5f * u(g)}, Q{1.5f * u(g), 1.5f * u(g)};
              float vc = 1.2f * u(g);
              if (k % 3 == 0) {  // through samples exactly: v on a sample's v, u on another's
                P.v = uv[g() % uv.size()].v;
                Q = uv[g() % uv.size()];
                vc = uv[g() % uv.size()].v;
              }
              const int w = int(g() % 5) - 2;
              dc.add_piece(P, Q, w);
              dc.add_step(vc, w);
              for (int j = 0; j < n; ++j) {
                const Vec2f& s = uv[size_t(j)];
                if (P.v != Q.v) {
                  const bool up = Q.v > P.v;
                  const Vec2f lo = up ? P : Q, hi = up ? Q : P;
                  const float cr = cross2(Vec2f{hi.u - lo.u, hi.v - lo.v}, Vec2f{s.u - lo.u, s.v - lo.v});
                  if (s.v >= lo.v && s.v < hi.v && cr > 0.0f && w != 0) naive[size_t(j)] += up ? w : -w;
                  // Unclear: within 1e-6 of the magnitudes (extent 2) of the piece's line,
                  // in its v-range (DepthCounter::add_piece); pieces of weight 0 add nothing.
                  const double m = 1e-6 * (2.0 + std::abs(lo.u) + std::abs(lo.v) + std::abs(hi.u) + std::abs(hi.v));
                  const double du = double(hi.u - lo.u), dv = double(hi.v - lo.v);
                  const float near = float(m * std::sqrt(du * du + dv * dv));
                  if (w != 0 && s.v >= lo.v && s.v < hi.v && std::abs(cr) <= near) naive_unclear[size_t(j)] = 1;
                }
                if (s.v >= vc) naive[size_t(j)] += w;
              }
            }
            std::vector<int32_t> got;
            std::vector<uint8_t> unclear;
            dc.finish(got, &unclear);
            EXPECT_EQ(got, naive) << "layout " << layout << " K = " << K << " spread " << spread << " n = " << n;
            // Exactly the samples the plain loop calls unclear are flagged: bulk decisions
            // never skip a sample within the margin.
            EXPECT_EQ(unclear, naive_unclear) << "layout " << layout << " K = " << K << " spread " << spread << " n = " << n;
          }
        }
}

TEST(SsvIntegration, StripSearchesEqualLowerBound) {
  // The strips' bucket searches against std::lower_bound, and vhi_prefix against the
  // running maximum of the boxes' v_hi in v_lo order, for every layout: x on every value,
  // its float neighbours, random and outside the range.
  std::mt19937_64 g(12);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  for (int layout = 0; layout <= 4; ++layout)
    for (int K : {1, 4})
      for (int n : {1, 7, 256, 1000}) {
        const std::vector<Vec2f> jitter = jitter_layout(layout, n, K, 0.1f, g);
        const SampleStrips s = make_sample_strips(jitter, n, K);
        float run = -std::numeric_limits<float>::infinity();
        for (int k = 0; k < n; ++k) {
          const int j = s.vorder[size_t(k)];
          for (int q = 0; q < K; ++q) run = std::max(run, jitter[size_t(j * K + q)].v);
          ASSERT_EQ(s.vhi_prefix[size_t(k)], run) << "layout " << layout << " n " << n << " k " << k;
        }
        std::vector<double> xs{-2.0, 2.0};
        for (int k = 0; k < n; ++k)
          for (float v : {s.vlo_sorted[size_t(k)], s.vhi_prefix[size_t(k)]}) {
            xs.push_back(v);
            xs.push_back(std::nextafter(v, -INFINITY));
            xs.push_back(std::nextafter(v, INFINITY));
          }
        for (int r = 0; r < 50; ++r) xs.push_back(u(g));
        auto lb = [](const std::vector<float>& a, double x) {
          return int(std::lower_bound(a.begin(), a.end(), x, [](float e, double y) { return double(e) < y; }) -
                     a.begin());
        };
        for (double x : xs) {
          ASSERT_EQ(s.vlo_lower_bound(x), lb(s.vlo_sorted, x)) << "layout " << layout << " x " << x;
          ASSERT_EQ(s.vhi_lower_bound(x), lb(s.vhi_prefix, x)) << "layout " << layout << " x " << x;
        }
      }
}

TEST(SsvIntegration, JitterPicksEqualSamplePosition) {
  // jitter_picks (four hashes at a time where AVX2 is there) against the definition,
  // relation_hash_step mod K, for power-of-two and other K, sample counts with and
  // without a tail, and prefixes with high bits set (the 64-bit products' carries).
  std::mt19937_64 g(5);
  std::vector<uint32_t> pick;
  for (int K : {1, 2, 3, 4, 16, 1024})
    for (int samples : {0, 1, 3, 4, 5, 64, 257})
      for (int trial = 0; trial < 20; ++trial) {
        const uint64_t prefix = trial == 0 ? ~uint64_t(0) : trial == 1 ? 0 : g();
        jitter_picks(prefix, samples, K, pick);
        ASSERT_EQ(pick.size(), size_t(samples));
        for (int j = 0; j < samples; ++j)
          ASSERT_EQ(pick[size_t(j)], uint32_t(uint64_t(j) * uint64_t(K) +
                                              relation_hash_step(prefix, uint64_t(j)) % uint64_t(K)))
              << "K " << K << " samples " << samples << " j " << j;
      }
  // Against sample_position itself for one light: receiver i's prefix.
  Light light;
  light.jitter = 4;
  light.seed = 77;
  for (size_t i : {size_t(0), size_t(5), size_t(1) << 40}) {
    jitter_picks(relation_hash_prefix(i, light.seed), 64, light.jitter, pick);
    for (int j = 0; j < 64; ++j)
      EXPECT_EQ(pick[size_t(j)] % 4u, uint32_t(relation_hash(i, uint64_t(j), light.seed) % 4u));
  }
}

TEST(SsvIntegration, FinishClassesEqualsFinishThenClasses) {
  // The fused finish (counts, unclear samples as one value, the two lowest classes) against
  // finish(depth, &unclear) and a plain scan: stratified and wide boxes, samples all
  // coincident or on a few points, pieces through samples exactly (unclear samples), with
  // no steps, as many as the AVX2 scan adds per block (up to 4) and more (folded), and
  // sizes below and above the one-by-one limit (strip order).
  std::mt19937_64 g(23);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int32_t kU = std::numeric_limits<int32_t>::max();
  for (int layout = 0; layout < 4; ++layout)
    for (int K : {1, 4})
      for (int n : {1, 5, 256, 2048})
        for (int n_steps : {0, 1, 3, 4, 5, 40}) {
          const std::vector<Vec2f> jitter = jitter_layout(layout, n, K, 0.02f, g);
          const SampleStrips strips = make_sample_strips(jitter, n, K);
          std::vector<uint32_t> pick(static_cast<size_t>(n));
          std::vector<Vec2f> uv(static_cast<size_t>(n));
          for (int j = 0; j < n; ++j) {
            pick[size_t(j)] = uint32_t(j * K + int(g() % uint64_t(K)));
            uv[size_t(j)] = jitter[pick[size_t(j)]];
          }
          DepthCounter a, b;
          a.reset(strips, jitter, pick, 2.0);
          // b once abandoned with steps and no finish: its next reset must clear them.
          b.reset(strips, jitter, pick, 2.0);
          b.add_step(uv[0].v, 3);
          b.add_step(-2.0f, -1);
          b.reset(strips, jitter, pick, 2.0);
          if (n_steps % 2 == 1) {  // both in the picked points' own v order (n <= 512)
            a.use_sorted_order();
            b.use_sorted_order();
          }
          for (int k = 0; k < 40; ++k) {
            Vec2f P{1.5f * u(g), 1.5f * u(g)}, Q{1.5f * u(g), 1.5f * u(g)};
            if (k % 2 == 0) {  // through samples exactly
              P = uv[g() % uv.size()];
              Q = uv[g() % uv.size()];
              if (P.v == Q.v) Q.v += 0.5f;
            }
            const int w = int(g() % 5) - 2;
            a.add_piece(P, Q, w);
            b.add_piece(P, Q, w);
            if (k < n_steps) {
              const float vc = k % 2 ? 1.2f * u(g) : uv[g() % uv.size()].v;
              a.add_step(vc, w);
              b.add_step(vc, w);
            }
          }
          std::vector<int32_t> depth, fused;
          std::vector<uint8_t> unclear;
          a.finish(depth, &unclear);
          size_t n_unclear = 0;
          int32_t dmin = kU, second = kU;
          for (size_t j = 0; j < depth.size(); ++j) {
            if (unclear[j]) depth[j] = kU, ++n_unclear;
            dmin = std::min(dmin, depth[j]);
          }
          for (int32_t x : depth)
            if (x > dmin) second = std::min(second, x);
          const DepthCounter::Classes c = b.finish_classes(fused, kU);
          const std::string where = "layout " + std::to_string(layout) + " K " + std::to_string(K) + " n " +
                                    std::to_string(n) + " steps " + std::to_string(n_steps);
          EXPECT_EQ(fused, depth) << where;
          EXPECT_EQ(c.unclear, n_unclear) << where;
          EXPECT_EQ(c.dmin, dmin) << where;
          EXPECT_EQ(c.second, second) << where;
        }
}

TEST(SsvIntegration, SortedOrderEqualsVloOrder) {
  // Up to 512 samples the counter may keep the picked points in their own v order
  // (use_sorted_order) instead of the boxes' v_lo order: the same counts,
  // flags and classes per sample. Stratified, wide, coincident and few-point layouts,
  // pieces and steps exactly on sample v's (ties at the range ends), weights of both signs.
  std::mt19937_64 g(31);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int32_t kU = std::numeric_limits<int32_t>::max();
  for (int layout = 0; layout < 4; ++layout)
    for (int K : {1, 4, 16})
      for (int n : {1, 2, 9, 64, 300, 512}) {
        const std::vector<Vec2f> jitter = jitter_layout(layout, n, K, 0.3f, g);
        const SampleStrips strips = make_sample_strips(jitter, n, K);
        for (int receiver = 0; receiver < 3; ++receiver) {
          std::vector<uint32_t> pick(static_cast<size_t>(n));
          for (int j = 0; j < n; ++j) pick[size_t(j)] = uint32_t(j * K + int(g() % uint64_t(K)));
          DepthCounter dc[4];
          for (int m = 0; m < 4; ++m) {
            dc[m].reset(strips, jitter, pick, 2.0);
            if (m % 2 == 1) {
              EXPECT_TRUE(dc[m].use_sorted_order());
            }
          }
          for (int k = 0; k < 120; ++k) {
            Vec2f P{1.5f * u(g), 1.5f * u(g)}, Q{1.5f * u(g), 1.5f * u(g)};
            float vc = 1.2f * u(g);
            if (k % 2 == 0) {
              P = jitter[pick[g() % pick.size()]];
              Q = jitter[pick[g() % pick.size()]];
              vc = jitter[pick[g() % pick.size()]].v;
            }
            const int w = int(g() % 5) - 2;
            for (auto& d : dc) {
              d.add_piece(P, Q, w);
              if (k % 7 == 0) d.add_step(vc, w);
            }
          }
          std::vector<int32_t> depth0, depth1, fused0, fused1;
          std::vector<uint8_t> unclear0, unclear1;
          dc[0].finish(depth0, &unclear0);
          dc[1].finish(depth1, &unclear1);
          const DepthCounter::Classes c0 = dc[2].finish_classes(fused0, kU), c1 = dc[3].finish_classes(fused1, kU);
          const std::string where =
              "layout " + std::to_string(layout) + " K " + std::to_string(K) + " n " + std::to_string(n);
          EXPECT_EQ(depth1, depth0) << where;
          EXPECT_EQ(unclear1, unclear0) << where;
          EXPECT_EQ(fused1, fused0) << where;
          EXPECT_EQ(c1.dmin, c0.dmin) << where;
          EXPECT_EQ(c1.second, c0.second) << where;
          EXPECT_EQ(c1.unclear, c0.unclear) << where;
        }
      }
}

TEST(SsvIntegration, RelativeDepthEqualsDirectCounting) {
  // Every edge of random scenes integrated (no culling) against direct counting of the
  // triangles crossing each segment: the difference must be one constant per receiver.
  size_t compared = 0;
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    Scene s = random_scene(seed, 64, 12);
    mesh::PreparedMesh pm = mesh::prepare_mesh(s.mesh);
    const Light& light = s.lights[0];
    LightFrame frame = make_light_frame(light);
    std::vector<Vec3d> fp = frame_positions(pm, frame);
    std::vector<Edge> edges = mesh_edges(pm);
    ReceiverIntegrator integ(pm, fp, frame);
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      std::vector<Vec2f> uv;
      for (int j = 0; j < light.samples; ++j) {
        size_t k = size_t(&sample_position(light, j, i) - light.jitter_points.data());
        uv.push_back(frame.jitter_uv[k]);
      }
      integ.begin(s.receivers[i].p, uv);
      for (const Edge& e : edges) integ.add_edge(e, integ.edge_weight(e));
      for (size_t t = 0; t < pm.triangles.size(); ++t) integ.add_cut(t);
      std::vector<int32_t> depth;
      integ.finish(depth);
      // The fast clearance test agrees with the distance it stands for, at the boundary
      // too (the threshold itself is a valid answer either way only when equal).
      for (int j = 0; j < light.samples; ++j)
        EXPECT_EQ(integ.clear(size_t(j)), integ.clearance(size_t(j)) >= integ.clearance_threshold()) << j;
      bool have = false;
      int offset = 0;
      for (int j = 0; j < light.samples; ++j) {
        int d = direct_depth(s.mesh, s.receivers[i].p, sample_position(light, j, i));
        if (d < 0) continue;
        ++compared;
        if (!have) {
          offset = depth[size_t(j)] - d;
          have = true;
        }
        EXPECT_EQ(depth[size_t(j)] - d, offset) << "seed " << seed << " receiver " << i << " sample " << j;
      }
    }
  }
  EXPECT_GT(compared, 3000u);
}

TEST(SsvIntegration, VertexReuseEqualsPerEdgeClipping) {
  // add_edge with each vertex projected once per receiver (set_vertex_reuse, the
  // default) against every edge clipped and projected on its own: the same counts,
  // unclear flags, classes, doubt and clearances, with the shared projections in use.
  const int32_t kU = std::numeric_limits<int32_t>::max();
  size_t reused = 0, receivers = 0;
  for (uint64_t seed = 1; seed <= 8; ++seed)
    for (int samples : {16, 64}) {
      Scene s = random_scene(seed, samples, 24);
      mesh::PreparedMesh pm = mesh::prepare_mesh(s.mesh);
      const Light& light = s.lights[0];
      LightFrame frame = make_light_frame(light);
      std::vector<Vec3d> fp = frame_positions(pm, frame);
      std::vector<Edge> edges = mesh_edges(pm);
      const SampleStrips strips = make_sample_strips(frame.jitter_uv, light.samples, light.jitter);
      ReceiverIntegrator on(pm, fp, frame), off(pm, fp, frame);
      off.set_vertex_reuse(false);
      std::vector<uint32_t> pick;
      for (size_t i = 0; i < s.receivers.size(); ++i) {
        if (!(frame.to_local(s.receivers[i].p).z > 0.0)) continue;
        jitter_picks(relation_hash_prefix(i, light.seed), light.samples, light.jitter, pick);
        std::vector<int32_t> depth[2];
        DepthCounter::Classes classes[2];
        ReceiverIntegrator* integ[2] = {&on, &off};
        for (int k = 0; k < 2; ++k) {
          integ[k]->begin(s.receivers[i].p, strips, pick);
          integ[k]->expect_edges(edges.size());
          for (const Edge& e : edges) {
            const int w = integ[k]->edge_weight(e);
            if (w != 0) integ[k]->add_edge(e, w);
          }
          for (size_t t = 0; t < pm.triangles.size(); ++t) integ[k]->add_cut(t);
          classes[k] = integ[k]->finish_classes(depth[k], kU);
        }
        const std::string where = "seed " + std::to_string(seed) + " receiver " + std::to_string(i);
        EXPECT_EQ(depth[0], depth[1]) << where;
        EXPECT_EQ(classes[0].dmin, classes[1].dmin) << where;
        EXPECT_EQ(classes[0].second, classes[1].second) << where;
        EXPECT_EQ(classes[0].unclear, classes[1].unclear) << where;
        EXPECT_EQ(on.doubtful(), off.doubtful()) << where;
        for (int j = 0; j < light.samples; ++j)
          EXPECT_EQ(on.clearance(size_t(j)), off.clearance(size_t(j))) << where << " sample " << j;
        EXPECT_EQ(off.reused_edges(), 0u);
        reused += on.reused_edges();
        ++receivers;
      }
    }
  EXPECT_GT(receivers, 100u);
  EXPECT_GT(reused, 10 * receivers);
}
