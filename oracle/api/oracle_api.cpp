// The public API's exact oracle (include/visgate/visgate.h, target visgate::oracle).
#include "lib/api/api_internal.h"
#include "oracle/comparator.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"

namespace visgate::api {

Classes classify(const Scene& scene, int threads) {
  const visgate::Scene& s = scene.impl();
  oracle::RelationOracleResult r = oracle::run_relation_oracle(s, threads);
  Classes c;
  c.receivers = s.receivers.size();
  c.relations_per_receiver = s.samples_per_receiver();
  c.cls.reserve(c.receivers * c.relations_per_receiver);
  c.margins.reserve(c.receivers * c.relations_per_receiver);
  for (size_t i = 0; i < c.receivers; ++i) {
    c.cls.insert(c.cls.end(), r.classes[i].begin(), r.classes[i].end());
    c.margins.insert(c.margins.end(), r.margins[i].begin(), r.margins[i].end());
  }
  c.seconds = r.seconds;
  return c;
}

Outcome<Region> visible_region(const Scene& scene, size_t receiver, size_t light) {
  const visgate::Scene& s = scene.impl();
  if (receiver >= s.receivers.size()) return Outcome<Region>::failure("receiver " + std::to_string(receiver) + ": out of range");
  if (light >= s.lights.size()) return Outcome<Region>::failure("light " + std::to_string(light) + ": out of range");
  oracle::RegionAnswer a = oracle::visible_region(s, receiver, light);
  Region r;
  r.visible_fraction = a.visible_fraction;
  for (const auto& poly : a.polygons) {
    Polygon p;
    for (const auto& v : poly) p.push_back(detail::to_api(v));
    r.polygons.push_back(std::move(p));
  }
  return r;
}

Outcome<Comparison> compare(const Scene& scene, const Solution& solution, double tau, int threads) {
  const visgate::Scene& s = scene.impl();
  if (solution.receivers != s.receivers.size() || solution.relations_per_receiver != s.samples_per_receiver() ||
      solution.lights != s.lights.size() || solution.visible.size() != solution.receivers * solution.relations_per_receiver ||
      solution.visible_fraction.size() != solution.receivers * solution.lights)
    return Outcome<Comparison>::failure("solution of " + solution.method + ": its shape does not match scene " + s.name);
  const SolveResult r = detail::to_solve_result(s, solution);
  oracle::Comparison c = oracle::compare_relations(s, r, oracle::run_relation_oracle(s, threads), tau);
  if (!solution.fragments.empty()) {
    std::vector<size_t> all(s.receivers.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    oracle::merge(c, oracle::compare_regions(s, r, all, tau));
  }
  Comparison out;
  out.relations = c.relations;
  out.degenerate = c.degenerate;
  out.agree = c.agree;
  out.disagree = c.disagree;
  out.false_visible = c.false_visible;
  out.false_blocked = c.false_blocked;
  out.fraction = c.fraction_mismatches;
  out.fragment = c.fragment_mismatches;
  for (const auto& m : c.mismatches) {
    if (out.mismatches.size() >= 1000) break;
    Mismatch x;
    oracle::copy_mismatch(m, x);
    out.mismatches.push_back(std::move(x));
  }
  return out;
}

}  // namespace visgate::api
