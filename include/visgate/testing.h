// GoogleTest helpers for checking a visibility method against visgate's exact oracle
// (include/visgate/visgate.h; link visgate::oracle and GTest):
//
//   #include <visgate/testing.h>
//   TEST(MyCaster, AgreesOnSharedEdges) {
//     EXPECT_TRUE(visgate::test::agrees_with_oracle("plugin:./libmy_caster.so", "shared-edge-fan"));
//   }
//
// agrees_with_oracle generates `count` scenes of the family (seeds first_seed, ...),
// solves each with the method and compares it with the exact classes (DESIGN section 5:
// a mismatch is a relation answered against a non-degenerate exact class with margin >=
// tau). On the first failing scene it minimises the first mismatch: the relation alone
// (one receiver, one explicit light point), then the fewest triangles that keep the same
// direction of error (delta debugging over triangles), and prints that scene's JSON, ready
// for `visgate solve`, `visgate oracle` or a regression test. Header only.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <sstream>
#include <string>
#include <vector>

#include "visgate/visgate.h"

namespace visgate::test {

struct AgreementOptions {
  uint64_t first_seed = 1;
  int count = 4;
  long triangles = -1, receivers = -1, samples = -1;  // family parameters; -1: its defaults
  double tau = 1e-5;
  api::SolveSettings settings;  // method options, threads, seed
  bool minimize = true;
};

namespace detail {

// The scene still shows a mismatch of `direction` under `method`.
inline bool fails_the_same_way(const api::Scene& s, const std::string& method, const AgreementOptions& o,
                               const std::string& direction) {
  auto sol = api::solve(s, method, o.settings);
  if (!sol) return false;
  auto cmp = api::compare(s, *sol, o.tau, o.settings.threads);
  if (!cmp) return false;
  for (const auto& m : cmp->mismatches)
    if (m.direction == direction) return true;
  return false;
}

// Delta debugging over the triangles of a one-relation scene.
inline api::Scene minimize_triangles(const api::Scene& s, const std::string& method, const AgreementOptions& o,
                                     const std::string& direction) {
  std::vector<size_t> keep(s.triangle_count());
  for (size_t t = 0; t < keep.size(); ++t) keep[t] = t;
  auto scene_of = [&](const std::vector<size_t>& ts) {
    std::vector<bool> mask(s.triangle_count(), false);
    for (size_t t : ts) mask[t] = true;
    return s.with_triangles(mask);
  };
  size_t chunk = std::max<size_t>(keep.size() / 2, 1);
  for (;;) {
    bool progress = false;
    for (size_t start = 0; start < keep.size();) {
      std::vector<size_t> candidate(keep.begin(), keep.begin() + std::ptrdiff_t(start));
      const size_t end = std::min(keep.size(), start + chunk);
      candidate.insert(candidate.end(), keep.begin() + std::ptrdiff_t(end), keep.end());
      if (fails_the_same_way(scene_of(candidate), method, o, direction)) {
        keep = std::move(candidate);
        progress = true;
      } else {
        start += chunk;
      }
    }
    if (progress) {
      chunk = std::min(chunk, std::max<size_t>(keep.size() / 2, 1));
      continue;
    }
    if (chunk == 1) break;
    chunk /= 2;
  }
  return scene_of(keep);
}

}  // namespace detail

inline ::testing::AssertionResult agrees_with_oracle(const std::string& method, const std::string& family,
                                                     const AgreementOptions& o = {}) {
  for (int k = 0; k < o.count; ++k) {
    const uint64_t seed = o.first_seed + uint64_t(k);
    auto scene = api::generate_family(family, seed, o.triangles, o.receivers, o.samples);
    if (!scene) return ::testing::AssertionFailure() << "family " << family << " seed " << seed << ": " << scene.error();
    auto sol = api::solve(*scene, method, o.settings);
    if (!sol) return ::testing::AssertionFailure() << method << " on " << scene->name() << ": " << sol.error();
    auto cmp = api::compare(*scene, *sol, o.tau, o.settings.threads);
    if (!cmp) return ::testing::AssertionFailure() << cmp.error();
    if (cmp->mismatch_count() == 0) continue;

    const api::Mismatch& m = cmp->mismatches.front();
    std::ostringstream msg;
    msg << method << " disagrees with the exact oracle on " << scene->name() << " (family " << family << ", seed "
        << seed << "): " << cmp->mismatch_count() << " mismatches (" << cmp->false_visible << " false-visible, "
        << cmp->false_blocked << " false-blocked, " << cmp->fraction << " fraction, " << cmp->fragment
        << " fragment) in " << cmp->relations << " relations; first: receiver " << m.receiver << ", light " << m.light
        << ", sample " << m.sample << ", exact '" << m.exact << "', method says "
        << (m.method_visible ? "visible" : "blocked") << ", margin " << m.margin << " (" << m.direction << ")";
    if (o.minimize && m.sample >= 0) {
      const api::Scene one = scene->single_relation(m.receiver, scene->relation_offset(m.light) + size_t(m.sample));
      if (detail::fails_the_same_way(one, method, o, m.direction)) {
        const api::Scene small = detail::minimize_triangles(one, method, o, m.direction);
        msg << "\nminimised to " << small.triangle_count() << " triangle(s), one relation:\n" << small.to_json();
      } else {
        msg << "\n(the relation alone is answered correctly: not minimised; the scene follows)\n" << scene->to_json();
      }
    }
    return ::testing::AssertionFailure() << msg.str();
  }
  return ::testing::AssertionSuccess();
}

}  // namespace visgate::test
