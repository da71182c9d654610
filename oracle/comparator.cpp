// The comparator (DESIGN section 5): mismatches, the disagreement histogram per margin
// decade and the counts by class and direction, from a method's SolveResult and the
// oracles' answers; plus the JSON report.
#include "oracle/comparator.h"

#include <cmath>
#include <memory>

#include "oracle/region_oracle.h"

namespace visgate::oracle {

const char* direction_name(Direction d) {
  switch (d) {
    case Direction::FalseVisible: return "false-visible";
    case Direction::FalseBlocked: return "false-blocked";
    case Direction::FractionError: return "fraction";
    case Direction::FragmentBlocked: return "fragment-blocked";
  }
  return "unknown";
}

namespace {
// Exact decade bounds 10^(k-12), k = 0..12, as correctly rounded doubles; comparing
// against them (instead of trusting floor(log10(m))) puts every margin in the bucket its
// decimal value belongs to, up to the rounding of the literals themselves.
constexpr double kDecade[13] = {1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0};

// Receiver i's exact classes (nullptr when the oracle left the receiver out), after
// checking that the oracle's margins and the method's bits cover all n relations.
const std::string* receiver_classes(const SolveResult& method, const RelationOracleResult& exact, size_t i, size_t n) {
  const std::string& cls = exact.classes[i];
  if (cls.empty()) return nullptr;
  VG_CHECK(cls.size() == n && exact.margins[i].size() == n);
  VG_CHECK(method.receivers[i].visible_bits.size() * 64 >= n);
  return &cls;
}
}  // namespace

void DecadeHistogram::add(double margin) {
  if (!(margin >= kDecade[0])) {  // also NaN
    ++below;
    return;
  }
  int k = 12;
  while (margin < kDecade[k]) --k;
  ++buckets[size_t(k)];
}

Comparison compare_relations(const Scene& scene, const SolveResult& method, const RelationOracleResult& exact,
                             double tau) {
  Comparison c;
  size_t n = scene.samples_per_receiver();
  VG_CHECK(method.receivers.size() == scene.receivers.size());
  VG_CHECK(exact.classes.size() == scene.receivers.size() && exact.margins.size() == scene.receivers.size());
  // Light and sample of bit b.
  std::vector<std::pair<size_t, long>> where(n);
  for (size_t l = 0, b = 0; l < scene.lights.size(); ++l)
    for (int j = 0; j < scene.lights[l].samples; ++j, ++b) where[b] = {l, long(j)};
  for (size_t i = 0; i < scene.receivers.size(); ++i) {
    const std::string* classes = receiver_classes(method, exact, i, n);
    if (!classes) continue;
    const std::string& cls = *classes;
    const ReceiverResult& rr = method.receivers[i];
    for (size_t b = 0; b < n; ++b) {
      ++c.relations;
      RelationClass e = RelationClass(cls[b]);
      if (e == RelationClass::Degenerate) {
        ++c.degenerate;
        continue;
      }
      bool mv = rr.visible(b), ev = e == RelationClass::Visible;
      if (mv == ev) {
        ++c.agree;
        continue;
      }
      ++c.disagree;
      double m = exact.margins[i][b];
      c.disagreement_margins.add(m);
      if (!(m >= tau)) continue;
      Mismatch mm;
      mm.receiver = i;
      mm.light = where[b].first;
      mm.sample = where[b].second;
      mm.exact = e;
      mm.method_visible = mv;
      mm.margin = m;
      mm.direction = mv ? Direction::FalseVisible : Direction::FalseBlocked;
      (mv ? c.false_visible : c.false_blocked)++;
      c.mismatches.push_back(mm);
    }
  }
  return c;
}

namespace {
// Interior point of a convex fragment: centroid of its largest fan triangle (double,
// rounded once to float). False for fragments of zero area.
bool interior_point(const Polygon3f& poly, Vec3f& out) {
  if (poly.size() < 3) return false;
  Vec3d o = to_double(poly[0]);
  double best = 0.0;
  for (size_t k = 1; k + 1 < poly.size(); ++k) {
    Vec3d a = to_double(poly[k]), b = to_double(poly[k + 1]);
    double area = length(cross(a - o, b - o));
    if (area > best) {
      best = area;
      out = Vec3f((o + a + b) / 3.0);
    }
  }
  return best > 0.0;
}
// True when the exact path's test below, !(|mf - exact fraction| <= tolerance) in double,
// certainly comes out false (no mismatch), or the pair is edge-on: decided from the
// certified enclosure [lo, hi] of the exact ratio. The exact path's fraction ef is the
// ratio rounded to double, so lo <= ef <= hi; fl(mf - ef) is monotone in ef, so
// |mf - ef| in double is at most the larger of its values at lo and at hi. Anything else
// (including every mismatch and NaN) goes to visible_region, which also makes the report.
bool fraction_certainly_within(const Scene& scene, size_t i, size_t l, double mf, RegionCache& cache) {
  FractionBound b = visible_fraction_bound(scene, i, l, &cache);
  if (b.edge_on) return true;
  return b.certified && std::abs(mf - b.lo) <= kFractionTolerance && std::abs(mf - b.hi) <= kFractionTolerance;
}
}  // namespace

void fill_disagreement_margins(const Scene& scene, const SolveResult& method, RelationOracleResult& exact) {
  VG_CHECK(method.receivers.size() == scene.receivers.size() && exact.classes.size() == scene.receivers.size());
  const size_t n = scene.samples_per_receiver();
  for (size_t i = 0; i < scene.receivers.size(); ++i) {
    const std::string* classes = receiver_classes(method, exact, i, n);
    if (!classes) continue;
    const std::string& cls = *classes;
    const ReceiverResult& rr = method.receivers[i];
    for (size_t l = 0, b = 0; l < scene.lights.size(); ++l)
      for (int j = 0; j < scene.lights[l].samples; ++j, ++b) {
        const RelationClass e = RelationClass(cls[b]);
        if (e == RelationClass::Degenerate || rr.visible(b) == (e == RelationClass::Visible)) continue;
        exact.margins[i][b] =
            classify_segment(scene, scene.receivers[i].p, sample_position(scene.lights[l], j, i)).margin;
      }
  }
}

Comparison compare_regions(const Scene& scene, const SolveResult& method, const std::vector<size_t>& receivers,
                           double tau, RegionParts parts) {
  Comparison c;
  VG_CHECK(method.receivers.size() == scene.receivers.size());
  std::unique_ptr<BlockedSegmentTest> blocked;  // built at the first fragment
  RegionCache cache(scene);  // light frames made once; a pair's fallback reuses its bound's preparation
  for (size_t i : receivers) {
    VG_CHECK(i < scene.receivers.size());
    const ReceiverResult& rr = method.receivers[i];
    for (size_t l = 0; l < scene.lights.size(); ++l) {
      if (parts.fractions && l < rr.visible_fraction.size() &&
          !fraction_certainly_within(scene, i, l, double(rr.visible_fraction[l]), cache)) {
        RegionOptions fraction_only;
        fraction_only.outputs = false;  // the fraction is all a verdict or a record needs
        RegionAnswer exact = visible_region(scene, i, l, fraction_only, &cache);
        double mf = double(rr.visible_fraction[l]);
        if (!exact.edge_on && !(std::abs(mf - exact.visible_fraction) <= kFractionTolerance)) {
          Mismatch mm;
          mm.receiver = i;
          mm.light = l;
          mm.direction = Direction::FractionError;
          mm.exact_fraction = exact.visible_fraction;
          mm.method_fraction = mf;
          mm.margin = std::abs(mf - exact.visible_fraction);
          ++c.fraction_mismatches;
          c.mismatches.push_back(mm);
        }
      }
      if (!parts.fragments || l >= rr.fragments.size()) continue;
      for (const Polygon3f& frag : rr.fragments[l]) {
        Vec3f x;
        if (!interior_point(frag, x)) continue;
        if (!blocked) blocked = std::make_unique<BlockedSegmentTest>(scene);
        if (!blocked->blocked(scene.receivers[i].p, x, tau)) continue;
        RelationAnswer a = classify_segment(scene, scene.receivers[i].p, x);  // the record's margin
        if (a.cls != RelationClass::Blocked || !(a.margin >= tau)) continue;
        Mismatch mm;
        mm.receiver = i;
        mm.light = l;
        mm.exact = a.cls;
        mm.method_visible = true;
        mm.margin = a.margin;
        mm.direction = Direction::FragmentBlocked;
        ++c.fragment_mismatches;
        c.mismatches.push_back(mm);
      }
    }
  }
  return c;
}

void MismatchCounts::add(const MismatchCounts& o) {
  relations += o.relations;
  degenerate += o.degenerate;
  agree += o.agree;
  disagree += o.disagree;
  false_visible += o.false_visible;
  false_blocked += o.false_blocked;
  fraction_mismatches += o.fraction_mismatches;
  fragment_mismatches += o.fragment_mismatches;
}

void write_counts(nlohmann::ordered_json& j, const MismatchCounts& c, size_t mismatches, CountNames names) {
  const bool row = names == CountNames::CheckRow;
  j["relations"] = c.relations;
  j["degenerate"] = c.degenerate;
  j["agree"] = c.agree;
  j["disagree"] = c.disagree;
  j["mismatches"] = mismatches;
  j["false_visible"] = c.false_visible;
  j["false_blocked"] = c.false_blocked;
  j[row ? "fraction" : "fraction_mismatches"] = c.fraction_mismatches;
  j[row ? "fragment" : "fragment_mismatches"] = c.fragment_mismatches;
}

void merge(Comparison& into, const Comparison& o) {
  into.add(o);
  for (size_t k = 0; k < into.disagreement_margins.buckets.size(); ++k)
    into.disagreement_margins.buckets[k] += o.disagreement_margins.buckets[k];
  into.disagreement_margins.below += o.disagreement_margins.below;
  into.mismatches.insert(into.mismatches.end(), o.mismatches.begin(), o.mismatches.end());
}

nlohmann::ordered_json comparison_json(const Comparison& c, size_t max_records) {
  using json = nlohmann::ordered_json;
  json j;
  write_counts(j, c, c.mismatch_count(), CountNames::Comparison);
  json h;
  h["below_1e-12"] = c.disagreement_margins.below;
  json dec = json::array();
  for (size_t k = 0; k < 12; ++k)
    dec.push_back(json{{"from", kDecade[k]}, {"to", kDecade[k + 1]}, {"count", c.disagreement_margins.buckets[k]}});
  h["decades"] = dec;
  h["at_least_1"] = c.disagreement_margins.buckets[12];
  j["disagreement_margins"] = h;
  json recs = json::array();
  for (size_t k = 0; k < c.mismatches.size() && k < max_records; ++k) {
    const Mismatch& m = c.mismatches[k];
    json r;
    r["receiver"] = m.receiver;
    r["light"] = m.light;
    r["sample"] = m.sample;
    r["direction"] = direction_name(m.direction);
    if (m.direction == Direction::FractionError) {
      r["exact_fraction"] = m.exact_fraction;
      r["method_fraction"] = m.method_fraction;
    } else {
      r["exact"] = std::string(1, char(m.exact));
      r["method"] = m.method_visible ? "v" : "b";
    }
    r["margin"] = m.margin;
    recs.push_back(std::move(r));
  }
  j["records"] = recs;
  j["records_truncated"] = c.mismatches.size() > max_records;
  return j;
}

}  // namespace visgate::oracle
