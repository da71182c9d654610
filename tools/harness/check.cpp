// The differential check (see check.h).
#include "tools/harness/check.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

#include "lib/scene/json_exact.h"

namespace visgate::harness {

void add_histogram(DecadeCounts& into, const oracle::DecadeHistogram& h) {
  into[0] += h.below;
  for (size_t k = 0; k < h.buckets.size(); ++k) into[k + 1] += h.buckets[k];
}

std::string decade_label(size_t d) {
  if (d == 0) return "<1e-12";
  if (d == kDecades - 1) return ">=1";
  return "1e" + std::to_string(int(d) - 13);
}

void Row::merge(const Row& o) {
  add(o);
  scenes += o.scenes;
  metamorphic += o.metamorphic;
  shaft_decided += o.shaft_decided;
  shaft_reported += o.shaft_reported;
  for (size_t d = 0; d < kDecades; ++d) {
    disagreements[d] += o.disagreements[d];
    relations_per_decade[d] += o.relations_per_decade[d];
  }
  seconds += o.seconds;
}

size_t CheckReport::mismatch_count() const {
  size_t n = 0;
  for (const auto& [k, row] : rows) n += row.mismatches();
  return n;
}

size_t CheckReport::mismatch_count(const std::string& method) const {
  size_t n = 0;
  for (const auto& [k, row] : rows)
    if (k.second == method) n += row.mismatches();
  return n;
}

namespace {

MismatchRecord base_record(const std::string& method, const SolveOptions& so, const Scene& scene,
                           const SceneOrigin& origin) {
  MismatchRecord m;
  m.method = method;
  m.options = so.opts;
  m.family = origin.family;
  m.scene = scene.name;
  m.scene_file = origin.file;
  m.seed = origin.seed;
  m.params = origin.params;
  return m;
}

// Bits of relation (receiver i, bit b) of two results differ.
template <class F>
void for_each_changed_bit(const Scene& scene, const SolveResult& a, const SolveResult& b, F&& f) {
  size_t bits = scene.samples_per_receiver();
  for (size_t i = 0; i < scene.receivers.size(); ++i) {
    const auto& wa = a.receivers[i].visible_bits;
    const auto& wb = b.receivers[i].visible_bits;
    for (size_t w = 0; w < wa.size(); ++w) {
      uint64_t x = wa[w] ^ wb[w];
      while (x) {
        size_t bit = w * 64 + size_t(__builtin_ctzll(x));
        x &= x - 1;
        if (bit < bits) f(i, bit);
      }
    }
  }
}

// Light index and sample of relation bit `bit`.
std::pair<size_t, long> light_and_sample(const Scene& scene, size_t bit) {
  size_t l = 0;
  while (l + 1 < scene.lights.size() && bit >= scene.light_offset(l + 1)) ++l;
  return {l, long(bit - scene.light_offset(l))};
}

}  // namespace

std::string method_of_label(const std::string& label) { return label.substr(0, label.find('#')); }

std::vector<int> metamorphic_scale_exponents(uint64_t key, const ScaleRange& range) {
  static constexpr int kNegative[] = {-120, -96, -64, -48, -40, -32, -16};
  static constexpr int kPositive[] = {16, 32, 48, 64, 96, 124};
  const uint64_t h = splitmix64(key);
  std::vector<int> out;
  for (int k : {kNegative[h % 7], kPositive[(h >> 32) % 6]}) {
    k = std::clamp(k, range.lo, range.hi);
    if (k != 0 && range.contains(k)) out.push_back(k);
  }
  return out;
}

namespace {

uint64_t name_key(const std::string& name) {
  uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a
  for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

// A metamorphic copy of the scene and what a method may change on it.
struct Variant {
  Scene scene;
  std::string what;     // "scale 2^k", "axes", "translate"
  bool exact_copy;      // scale: every bit and fraction must be identical
};

}  // namespace

void check_scene(const Scene& scene, const SceneOrigin& origin, const CheckConfig& cfg, CheckReport& report) {
  const std::string family = origin.family;
  oracle::RelationOracleResult exact = oracle::run_relation_oracle(scene, cfg.threads);
  SceneSummary sum;
  sum.name = scene.name;
  sum.family = family;
  sum.file = origin.file;
  sum.seed = origin.seed;
  sum.triangles = scene.mesh.size();
  sum.relations = scene.relation_count();
  sum.oracle_seconds = exact.seconds;
  report.scenes.push_back(sum);

  DecadeCounts rel_hist{};
  {
    oracle::DecadeHistogram h;
    for (size_t i = 0; i < exact.classes.size(); ++i)
      for (size_t b = 0; b < exact.classes[i].size(); ++b)
        if (exact.classes[i][b] != 'd') h.add(exact.margins[i][b]);
    add_histogram(rel_hist, h);
  }

  std::vector<Variant> variants;
  if (cfg.metamorphic) {
    const ScaleRange range = exact_scale_range(scene);
    std::vector<int> exps = cfg.scale_exponents;
    if (exps.empty()) exps = metamorphic_scale_exponents(name_key(scene.name), range);
    for (int k : exps)
      if (k != 0 && range.contains(k))
        variants.push_back({scaled_scene(scene, k), "scale 2^" + std::to_string(k), true});
    variants.push_back({axis_mapped_scene(scene, axis_map(1 + unsigned(name_key(scene.name) % 47u))), "axes", false});
    variants.push_back({translated_scene(scene, nullptr), "translate", false});
    // The oracle itself: its classes are invariant under the exact maps.
    size_t changed = 0;
    double seconds = exact.seconds;
    MismatchRecord rec = base_record("oracle", SolveOptions{}, scene, origin);
    for (const Variant& v : variants) {
      if (v.exact_copy) continue;
      oracle::RelationOracleResult ev = oracle::run_relation_oracle_classes(v.scene, cfg.threads);
      seconds += ev.seconds;
      for (size_t i = 0; i < exact.classes.size(); ++i)
        for (size_t b = 0; b < exact.classes[i].size(); ++b)
          if (exact.classes[i][b] != ev.classes[i][b]) {
            if (++changed <= kMaxRecords) {
              auto [l, j] = light_and_sample(scene, b);
              rec.receiver = i, rec.light = l, rec.sample = j;
              rec.exact = exact.classes[i][b];
              rec.method_visible = ev.classes[i][b] == 'v';
              rec.margin = exact.margins[i][b];
              rec.direction = v.what;
              rec.kind = "metamorphic";
              report.mismatches.push_back(rec);
            }
          }
    }
    Row& orow = report.rows[{family, "oracle"}];
    orow.scenes += 1;
    orow.relations += scene.relation_count();
    orow.metamorphic += changed;
    orow.seconds += seconds;
  }

  for (const auto& m : cfg.methods) {
    auto solver = make_solver(m.name);
    Row& row = report.rows[{family, m.row()}];
    if (!solver) {
      report.errors.push_back(scene.name + ": unknown method " + m.name);
      continue;
    }
    SolveResult res;
    try {
      res = solver->solve(scene, m.options);
    } catch (const std::exception& e) {
      report.errors.push_back(scene.name + ": method " + m.row() + " threw: " + e.what());
      continue;
    }
    // The oracle's mismatches as records, at most kMaxRecords of one comparison.
    auto add_records = [&](const oracle::Comparison& c) {
      for (size_t k = 0; k < c.mismatches.size() && k < kMaxRecords; ++k) {
        MismatchRecord rec = base_record(m.name, m.options, scene, origin);
        oracle::copy_mismatch(c.mismatches[k], rec);
        rec.kind = "oracle";
        report.mismatches.push_back(rec);
      }
    };
    oracle::Comparison cmp = oracle::compare_relations(scene, res, exact, cfg.tau);
    row.scenes += 1;
    row.add(cmp);
    if (const Stats::Entry* e = res.stats.find("relations_blocked_by_shaft")) {
      row.shaft_decided += size_t(e->second + res.stats.get("relations_visible_by_empty_shaft"));
      row.shaft_reported += scene.relation_count();
    }
    add_histogram(row.disagreements, cmp.disagreement_margins);
    for (size_t d = 0; d < kDecades; ++d) row.relations_per_decade[d] += rel_hist[d];
    row.seconds += res.seconds;
    add_records(cmp);
    // Fragment methods: fractions and fragments against the region and relation oracles.
    if (solver->reports_fragments() && cfg.region_pairs > 0 && !scene.lights.empty()) {
      const size_t n = scene.receivers.size(), per = scene.lights.size();
      const size_t fit = std::max<size_t>(1, cfg.region_pairs / per);
      const size_t stride = n <= fit ? 1 : (n + fit - 1) / fit;
      std::vector<size_t> pick;
      for (size_t i = 0; i < n; i += stride) pick.push_back(i);
      oracle::Comparison reg = oracle::compare_regions(scene, res, pick, cfg.tau);
      // Only the fraction and fragment counts: the relations were counted above.
      row.fraction_mismatches += reg.fraction_mismatches;
      row.fragment_mismatches += reg.fragment_mismatches;
      // Region mismatches have sample -1 and exact 'b' (fragment-blocked: the point's
      // class) or 'v' (fraction: Mismatch's default).
      add_records(reg);
    }

    // Metamorphic: an exact 2^k copy must change no bit and no fraction; under the other
    // maps a bit may change only below tau.
    for (const Variant& v : variants) {
      SolveResult vr;
      try {
        vr = solver->solve(v.scene, m.options);
      } catch (const std::exception& e) {
        report.errors.push_back(scene.name + " (" + v.what + "): method " + m.row() + " threw: " + e.what());
        continue;
      }
      size_t changed = 0;
      auto record = [&](size_t i, long bit, char cls, double margin, bool visible) {
        if (++changed > kMaxRecords) return;
        MismatchRecord rec = base_record(m.name, m.options, scene, origin);
        if (bit >= 0) {
          auto [l, j] = light_and_sample(scene, size_t(bit));
          rec.light = l, rec.sample = j;
        }
        rec.receiver = i;
        rec.exact = cls;
        rec.method_visible = visible;
        rec.margin = margin;
        rec.direction = v.what;
        rec.kind = "metamorphic";
        report.mismatches.push_back(rec);
      };
      for_each_changed_bit(scene, res, vr, [&](size_t i, size_t bit) {
        const double margin = exact.margins[i][bit];
        const char cls = exact.classes[i][bit];
        if (!v.exact_copy && (cls == 'd' || margin < cfg.tau)) return;
        record(i, long(bit), cls, margin, vr.receivers[i].visible(bit));
      });
      if (v.exact_copy)
        for (size_t i = 0; i < res.receivers.size(); ++i)
          if (res.receivers[i].visible_fraction != vr.receivers[i].visible_fraction) record(i, -1, 'v', 0.0, true);
      row.metamorphic += changed;
    }
  }
}

Result<std::pair<int, int>> parse_shard(const std::string& text) {
  auto slash = text.find('/');
  int k = 0, n = 0;
  try {
    size_t p1 = 0, p2 = 0;
    if (slash == std::string::npos) throw 0;
    k = std::stoi(text.substr(0, slash), &p1);
    n = std::stoi(text.substr(slash + 1), &p2);
    if (p1 != slash || p2 != text.size() - slash - 1) throw 0;
  } catch (...) {
    return Error{"--shard " + text + ": expected k/N with integers 1 <= k <= N"};
  }
  if (n < 1 || k < 1 || k > n) return Error{"--shard " + text + ": expected k/N with integers 1 <= k <= N"};
  return std::make_pair(k, n);
}

// ---- JSON --------------------------------------------------------------------------

namespace {
using ojson = nlohmann::ordered_json;

ojson decades_json(const DecadeCounts& d) {
  ojson a = ojson::array();
  for (size_t x : d) a.push_back(x);
  return a;
}

ojson record_json(const MismatchRecord& m) {
  ojson o;
  o["method"] = m.method;
  ojson opts = ojson::object();
  for (const auto& [k, v] : m.options) opts[k] = v;
  o["options"] = opts;
  o["family"] = m.family;
  o["scene"] = m.scene;
  if (!m.scene_file.empty()) o["scene_file"] = m.scene_file;
  o["seed"] = m.seed;
  o["params"] = {{"triangles", m.params.triangles}, {"receivers", m.params.receivers},
                 {"samples", m.params.samples}, {"light_scale", m.params.light_scale},
                 {"scale_exponent", m.params.scale_exponent}};
  o["receiver"] = m.receiver;
  o["light"] = m.light;
  o["sample"] = m.sample;
  o["exact"] = std::string(1, m.exact);
  o["method_answer"] = m.method_visible ? "visible" : "blocked";
  o["margin"] = m.margin;
  o["direction"] = m.direction;
  o["kind"] = m.kind;
  if (!m.stored.empty()) o["stored"] = m.stored;
  return o;
}
}  // namespace

std::string report_to_json(const CheckReport& r) {
  ojson doc;
  doc["format"] = "visgate-check-report";
  doc["version"] = 1;
  doc["tau"] = r.tau;
  doc["methods"] = r.methods;
  doc["shards"] = r.shards;
  doc["decades"] = [] {
    ojson a = ojson::array();
    for (size_t d = 0; d < kDecades; ++d) a.push_back(decade_label(d));
    return a;
  }();
  ojson rows = ojson::array();
  for (const auto& [key, row] : r.rows) {
    ojson o;
    o["family"] = key.first;
    o["method"] = key.second;
    o["scenes"] = row.scenes;
    oracle::write_counts(o, row, row.mismatches(), oracle::CountNames::CheckRow);
    o["metamorphic"] = row.metamorphic;
    o["shaft_decided"] = row.shaft_decided;
    o["shaft_reported"] = row.shaft_reported;
    o["disagreements_per_decade"] = decades_json(row.disagreements);
    o["relations_per_decade"] = decades_json(row.relations_per_decade);
    o["seconds"] = row.seconds;
    rows.push_back(o);
  }
  doc["rows"] = rows;
  ojson scenes = ojson::array();
  for (const auto& s : r.scenes) {
    ojson o;
    o["name"] = s.name;
    o["family"] = s.family;
    if (!s.file.empty()) o["file"] = s.file;
    o["seed"] = s.seed;
    o["triangles"] = s.triangles;
    o["relations"] = s.relations;
    o["oracle_seconds"] = s.oracle_seconds;
    scenes.push_back(o);
  }
  doc["scenes"] = scenes;
  ojson mm = ojson::array();
  for (const auto& m : r.mismatches) mm.push_back(record_json(m));
  doc["mismatches"] = mm;
  doc["errors"] = r.errors;
  doc["total_mismatches"] = r.mismatch_count();
  return doc.dump(1) + "\n";
}

Result<CheckReport> report_from_json(const std::string& text, const std::string& origin) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    return Error{origin + ": JSON parse error: " + e.what()};
  }
  if (!doc.is_object() || doc.value("format", "") != "visgate-check-report")
    return Error{origin + ": format: expected \"visgate-check-report\""};
  if (doc.value("version", 0) != 1) return Error{origin + ": version: expected 1"};
  CheckReport r;
  std::string where = "";
  try {
    where = "tau";
    r.tau = doc.at("tau").get<double>();
    where = "methods";
    r.methods = doc.at("methods").get<std::vector<std::string>>();
    where = "shards";
    r.shards = doc.at("shards").get<std::vector<std::string>>();
    auto decades = [](const nlohmann::json& a) {
      DecadeCounts d{};
      if (!a.is_array() || a.size() != kDecades) throw std::runtime_error("expected 14 decade counts");
      for (size_t k = 0; k < kDecades; ++k) d[k] = a[k].get<size_t>();
      return d;
    };
    const auto& rows = doc.at("rows");
    for (size_t i = 0; i < rows.size(); ++i) {
      where = "rows[" + std::to_string(i) + "]";
      const auto& o = rows[i];
      Row row;
      row.scenes = o.at("scenes").get<size_t>();
      row.relations = o.at("relations").get<size_t>();
      row.degenerate = o.at("degenerate").get<size_t>();
      row.agree = o.at("agree").get<size_t>();
      row.disagree = o.at("disagree").get<size_t>();
      row.false_visible = o.at("false_visible").get<size_t>();
      row.false_blocked = o.at("false_blocked").get<size_t>();
      row.fraction_mismatches = o.at("fraction").get<size_t>();
      row.fragment_mismatches = o.at("fragment").get<size_t>();
      row.metamorphic = o.at("metamorphic").get<size_t>();
      row.shaft_decided = o.value("shaft_decided", size_t(0));
      row.shaft_reported = o.value("shaft_reported", size_t(0));
      row.disagreements = decades(o.at("disagreements_per_decade"));
      row.relations_per_decade = decades(o.at("relations_per_decade"));
      row.seconds = o.at("seconds").get<double>();
      r.rows[{o.at("family").get<std::string>(), o.at("method").get<std::string>()}].merge(row);
    }
    const auto& scenes = doc.at("scenes");
    for (size_t i = 0; i < scenes.size(); ++i) {
      where = "scenes[" + std::to_string(i) + "]";
      const auto& o = scenes[i];
      SceneSummary s;
      s.name = o.at("name").get<std::string>();
      s.family = o.at("family").get<std::string>();
      s.file = o.value("file", "");
      s.seed = o.at("seed").get<uint64_t>();
      s.triangles = o.at("triangles").get<size_t>();
      s.relations = o.at("relations").get<size_t>();
      s.oracle_seconds = o.at("oracle_seconds").get<double>();
      r.scenes.push_back(s);
    }
    const auto& mm = doc.at("mismatches");
    for (size_t i = 0; i < mm.size(); ++i) {
      where = "mismatches[" + std::to_string(i) + "]";
      const auto& o = mm[i];
      MismatchRecord m;
      m.method = o.at("method").get<std::string>();
      for (const auto& [k, v] : o.at("options").items()) m.options[k] = v.get<std::string>();
      m.family = o.at("family").get<std::string>();
      m.scene = o.at("scene").get<std::string>();
      m.scene_file = o.value("scene_file", "");
      m.seed = o.at("seed").get<uint64_t>();
      const auto& p = o.at("params");
      m.params.seed = m.seed;
      m.params.triangles = p.at("triangles").get<long>();
      m.params.receivers = p.at("receivers").get<long>();
      m.params.samples = p.at("samples").get<long>();
      m.params.light_scale = p.at("light_scale").get<double>();
      m.params.scale_exponent = p.value("scale_exponent", 0);
      m.receiver = o.at("receiver").get<size_t>();
      m.light = o.at("light").get<size_t>();
      m.sample = o.at("sample").get<long>();
      m.exact = o.at("exact").get<std::string>().at(0);
      m.method_visible = o.at("method_answer").get<std::string>() == "visible";
      m.margin = o.at("margin").get<double>();
      m.direction = o.at("direction").get<std::string>();
      m.kind = o.at("kind").get<std::string>();
      m.stored = o.value("stored", "");
      r.mismatches.push_back(m);
    }
    where = "errors";
    r.errors = doc.at("errors").get<std::vector<std::string>>();
  } catch (const std::exception& e) {
    return Error{origin + ": " + where + ": " + e.what()};
  }
  return r;
}

Status merge_report(CheckReport& into, const CheckReport& other) {
  if (into.shards.empty() && into.rows.empty() && into.scenes.empty()) {
    into = other;
    return {};
  }
  if (into.tau != other.tau)
    return Error{"tau differs between reports (" + std::to_string(into.tau) + " vs " + std::to_string(other.tau) + ")"};
  if (into.methods != other.methods) return Error{"the reports checked different methods"};
  for (const auto& s : other.shards)
    if (std::find(into.shards.begin(), into.shards.end(), s) != into.shards.end() && s.find('/') != std::string::npos &&
        s != "1/1")
      return Error{"shard " + s + " appears in two reports"};
  into.shards.insert(into.shards.end(), other.shards.begin(), other.shards.end());
  for (const auto& [k, row] : other.rows) into.rows[k].merge(row);
  into.scenes.insert(into.scenes.end(), other.scenes.begin(), other.scenes.end());
  into.mismatches.insert(into.mismatches.end(), other.mismatches.begin(), other.mismatches.end());
  into.errors.insert(into.errors.end(), other.errors.begin(), other.errors.end());
  return {};
}

std::string format_table(const CheckReport& r) {
  std::string out;
  char buf[512];
  // Decades shown: those below tau (the disagreements that do not fail).
  std::snprintf(buf, sizeof buf, "%-18s %-18s %6s %10s %8s %9s %6s %6s %6s %6s %6s  %-40s %9s %7s\n", "family", "method",
                "scenes", "relations", "degen", "mismatch", "f-vis", "f-blk", "frac", "frag", "meta",
                "disagreements below tau per decade", "seconds", "shafts");
  out += buf;
  std::string hdr;
  for (size_t d = 0; d < kDecades; ++d) {
    double lo = d == 0 ? 0.0 : std::pow(10.0, double(d) - 13.0);
    if (d > 0 && lo >= r.tau) break;
    if (!hdr.empty()) hdr += ' ';
    hdr += decade_label(d);
  }
  std::snprintf(buf, sizeof buf, "%-18s %-18s %6s %10s %8s %9s %6s %6s %6s %6s %6s  %-40s\n", "", "", "", "", "", "", "",
                "", "", "", "", ("[" + hdr + "]").c_str());
  out += buf;
  for (const auto& [key, row] : r.rows) {
    std::string dec;
    for (size_t d = 0; d < kDecades; ++d) {
      double lo = d == 0 ? 0.0 : std::pow(10.0, double(d) - 13.0);
      if (d > 0 && lo >= r.tau) break;
      if (!dec.empty()) dec += ' ';
      dec += std::to_string(row.disagreements[d]);
    }
    // Share of relations decided by shafts (iss), so that a regression of the blocking
    // test cannot hide behind leaf rays.
    char shafts[16] = "-";
    if (row.shaft_reported > 0)
      std::snprintf(shafts, sizeof shafts, "%.1f%%", 100.0 * double(row.shaft_decided) / double(row.shaft_reported));
    std::snprintf(buf, sizeof buf, "%-18s %-18s %6zu %10zu %8zu %9zu %6zu %6zu %6zu %6zu %6zu  %-40s %9.3f %7s\n",
                  key.first.c_str(), key.second.c_str(), row.scenes, row.relations, row.degenerate, row.mismatches(),
                  row.false_visible, row.false_blocked, row.fraction_mismatches, row.fragment_mismatches, row.metamorphic,
                  ("[" + dec + "]").c_str(), row.seconds, shafts);
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "total: %zu scenes, %zu mismatches, %zu errors\n", r.scenes.size(), r.mismatch_count(),
                r.errors.size());
  out += buf;
  return out;
}

}  // namespace visgate::harness
