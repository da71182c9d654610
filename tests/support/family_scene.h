// Test fixtures: a generated family scene (lib/scene/families.h), failing the current
// test when the family rejects its parameters; the closed-manifold expectation of the
// families that model solids.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "lib/mesh/prepare.h"
#include "lib/scene/families.h"

namespace visgate::test_support {

inline Scene family(const std::string& f, uint64_t seed, long tris = -1, long recv = -1, long samples = -1,
                    double light_scale = 1.0) {
  FamilyParams p;
  p.seed = seed;
  p.triangles = tris;
  p.receivers = recv;
  p.samples = samples;
  p.light_scale = light_scale;
  auto r = generate_family(f, p);
  EXPECT_TRUE(r.ok()) << f << ": " << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(*r) : Scene{};
}

// After lib/mesh/prepare: every edge shared by exactly two consistently oriented
// triangles, nothing degenerate removed.
inline void expect_closed_manifold(const Scene& s) {
  mesh::PrepareCounts c;
  mesh::PreparedMesh m = mesh::prepare_mesh(s.mesh, &c);
  EXPECT_EQ(mesh::validate(m), "");
  EXPECT_EQ(c.single_edges, 0u);
  EXPECT_EQ(c.inconsistent_joins, 0u);
  EXPECT_EQ(c.nonmanifold_edges, 0u);
  EXPECT_EQ(c.degenerate_removed, 0u);
}

}  // namespace visgate::test_support
