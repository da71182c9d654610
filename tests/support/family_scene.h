// Test fixture: a generated family scene (lib/scene/families.h), failing the current
// test when the family rejects its parameters.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "lib/scene/families.h"

namespace visgate::test_support {

inline Scene family(const std::string& f, uint64_t seed, long tris = -1, long recv = -1, long samples = -1) {
  FamilyParams p;
  p.seed = seed;
  p.triangles = tris;
  p.receivers = recv;
  p.samples = samples;
  auto r = generate_family(f, p);
  EXPECT_TRUE(r.ok()) << f << ": " << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(*r) : Scene{};
}

}  // namespace visgate::test_support
