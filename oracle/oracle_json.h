// Oracle JSON (format "visgate-oracle", version 1; DESIGN section 5): writer and reader.
//   { "format": "visgate-oracle", "version": 1, "tau": 1e-5,
//     "receivers": [ {"classes": "vvbd...", "margins": [...],
//                     "regions": [ {"light": 0, "visible_fraction": 0.42,
//                                   "polygons": [ [[x,y,z],...], ... ],
//                                   "holes": [false, ...], "irradiance": 0.1,
//                                   "edge_on": false} ]}, ... ] }
// `regions` only when region answers are given. Added keys: "scene" (the scene name),
// "seconds" (relation oracle wall time), and per region "holes" (parallel to polygons:
// true for a hole boundary), "irradiance" (region_oracle.h) and "edge_on". Polygon
// coordinates are float32 written as 9-significant-digit decimals (bit-exact read back
// with strtof); margins and fractions are doubles in shortest round-trip form.
#pragma once

#include <string>
#include <vector>

#include "lib/base/result.h"
#include "lib/scene/scene.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"

namespace visgate::oracle {

inline constexpr double kDefaultTau = 1e-5;

// regions: empty, or one row per receiver with one answer per light.
std::string write_oracle_json(const Scene& scene, const RelationOracleResult& relations,
                              const std::vector<std::vector<RegionAnswer>>& regions, double tau = kDefaultTau);

// Reads classes, margins and tau back (regions are not read); numbers are parsed as
// doubles. Errors name `origin` and the element.
struct OracleFile {
  double tau = kDefaultTau;
  RelationOracleResult relations;
};
Result<OracleFile> read_oracle_json(const std::string& text, const std::string& origin);

}  // namespace visgate::oracle
