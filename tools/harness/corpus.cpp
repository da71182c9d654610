// The regression corpus (see corpus.h).
#include "tools/harness/corpus.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "lib/scene/json_exact.h"
#include "lib/scene/scene_json.h"
#include "tools/harness/sha1.h"

namespace visgate::harness {

namespace fs = std::filesystem;

const std::vector<std::string>& corpus_classes() {
  static const std::vector<std::string> c = {"torus",         "pouch",          "double-surface", "coplanar",
                                             "vertex-on-segment", "edge-on-segment", "near-endpoint", "far-origin",
                                             "sliver",        "other"};
  return c;
}

namespace {

// Distance between segments p0p1 and q0q1 (closest points, clamped; Ericson, Real-Time
// Collision Detection 5.1.9). A point x is the segment xx: its distance to a segment.
double segment_segment(const Vec3d& p0, const Vec3d& p1, const Vec3d& q0, const Vec3d& q1) {
  Vec3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  double s = 0, t = 0;
  if (a <= 0 && e <= 0) return length(r);
  if (a <= 0) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    double c = dot(d1, r);
    if (e <= 0) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      double b = dot(d1, d2), den = a * e - b * b;
      s = den > 0 ? std::clamp((b * f - c * e) / den, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1) {
        t = 1;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return length((p0 + d1 * s) - (q0 + d2 * t));
}

}  // namespace

// Tolerances, relative to the scene diagonal D: float32 inputs carry a relative rounding
// of 2^-24 ~ 6e-8 per coordinate, so features within 1e-6 D (about 16 roundings) of the
// segment are "on" it for classification purposes; a plane within 1e-7 D of both
// endpoints is coplanar with the segment; a crossing within 1e-6 D of an endpoint is
// near-endpoint; a triangle whose height is below 1e-3 of its longest edge is a sliver.
std::string classify_case(const Scene& scene, size_t receiver, size_t light, long sample, const std::string& family) {
  if (family == "torus" || family == "pouch" || family == "double-surface" || family == "far-origin") return family;
  if (family == "sliver-soup") return "sliver";
  double D = std::max(scene.bounds().diagonal(), 1e-30);
  Vec3d p = to_double(scene.receivers[receiver].p);
  Vec3d q = to_double(sample_position(scene.lights[light], int(sample), receiver));
  const double on = 1e-6 * D, plane_tol = 1e-7 * D;
  bool coplanar = false, vertex = false, edge = false, endpoint = false, sliver = false;
  for (size_t t = 0; t < scene.mesh.size(); ++t) {
    Vec3d a = to_double(scene.mesh.corner(t, 0)), b = to_double(scene.mesh.corner(t, 1)), c = to_double(scene.mesh.corner(t, 2));
    Vec3d n = cross(b - a, c - a);
    double nl = length(n);
    double longest = std::max({length(b - a), length(c - b), length(a - c)});
    if (longest > 0 && nl / longest < 1e-3 * longest) sliver = true;
    if (nl > 0) {
      double dp = dot(p - a, n) / nl, dq = dot(q - a, n) / nl;
      if (std::abs(dp) < plane_tol && std::abs(dq) < plane_tol) coplanar = true;
      if (dp * dq < 0) {
        double s = dp / (dp - dq);
        double len = length(q - p);
        if (std::min(s, 1 - s) * len < on) endpoint = true;
      }
    }
    for (const Vec3d& v : {a, b, c})
      if (segment_segment(v, v, p, q) < on) vertex = true;
    for (int k = 0; k < 3; ++k) {
      Vec3d u = to_double(scene.mesh.corner(t, k)), w = to_double(scene.mesh.corner(t, (k + 1) % 3));
      if (segment_segment(p, q, u, w) < on) edge = true;
    }
  }
  if (coplanar) return "coplanar";
  if (vertex) return "vertex-on-segment";
  if (edge) return "edge-on-segment";
  if (endpoint) return "near-endpoint";
  if (sliver) return "sliver";
  return "other";
}

std::string corpus_entry_text(const Scene& scene, const CaseInfo& info) {
  std::string text = write_scene_json(scene);
  // write_scene_json ends with "}\n": splice the case object in before the last brace.
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  VG_CHECK(!text.empty() && text.back() == '}');
  text.pop_back();
  nlohmann::ordered_json c;
  c["method"] = info.method;
  nlohmann::ordered_json opts = nlohmann::ordered_json::object();
  for (const auto& [k, v] : info.options) opts[k] = v;
  c["options"] = opts;
  c["receiver"] = info.receiver;
  c["light"] = info.light;
  c["sample"] = info.sample;
  c["tau"] = info.tau;
  c["expected"] = info.expected == 'b' ? "blocked" : "visible";
  c["method_answer"] = info.method_visible ? "visible" : "blocked";
  c["margin"] = info.margin;
  c["direction"] = info.direction;
  c["class"] = info.class_name;
  c["provenance"] = {{"family", info.family},
                     {"seed", info.seed},
                     {"scene", info.source_scene},
                     {"receiver", info.source_receiver},
                     {"light", info.source_light},
                     {"sample", info.source_sample},
                     {"triangles", info.source_triangles},
                     {"tool", info.tool}};
  c["status"] = info.status;
  c["note"] = info.note;
  return text + ",\n\"case\":" + c.dump(1) + "}\n";
}

namespace {
// The corpus folder of a method (DESIGN section 8: corpus/<method>/...): its name, or for
// an external method (exec:CMD, plugin:PATH, which hold slashes and spaces) the name
// with every character outside [A-Za-z0-9._-] replaced by '_', its tail kept and a hash
// of the whole name added when it is long.
std::string method_folder(const std::string& method) {
  if (method.rfind("exec:", 0) != 0 && method.rfind("plugin:", 0) != 0) return method;
  std::string s = method;
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-') c = '_';
  if (s.size() > 64) s = s.substr(0, s.find('_')) + "-" + sha1_hex(method).substr(0, 8) + "-" + s.substr(s.size() - 40);
  return s;
}
}  // namespace

Result<std::string> write_corpus_entry(const std::string& root, const Scene& scene, const CaseInfo& info) {
  const auto& cls = corpus_classes();
  if (std::find(cls.begin(), cls.end(), info.class_name) == cls.end())
    return Error{"corpus class " + info.class_name + " is not one of DESIGN section 8"};
  std::string text = corpus_entry_text(scene, info);
  fs::path dir = fs::path(root) / method_folder(info.method) / info.class_name;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Error{dir.string() + ": cannot create folder: " + ec.message()};
  fs::path path = dir / (sha1_hex(text) + ".json");
  if (fs::exists(path)) return path.string();
  Status st = write_file_atomic(path.string(), text);
  if (!st) return st.error();
  return path.string();
}

Result<CorpusEntry> read_corpus_entry(const std::string& path) {
  auto text = read_text_file(path);
  if (!text) return text.error();
  std::string base = fs::path(path).parent_path().string();
  auto scene = read_scene_json(*text, path, base.empty() ? "." : base);
  if (!scene) return scene.error();
  // The case object holds doubles (tau, margin): parse it with double precision, not
  // with the float32 scene parser.
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(*text);
  } catch (const std::exception& ex) {
    return Error{path + ": JSON parse error: " + ex.what()};
  }
  if (!doc.contains("case") || !doc["case"].is_object()) return Error{path + ": case: missing"};
  const auto& c = doc["case"];
  CorpusEntry e;
  e.path = path;
  e.scene = std::move(*scene);
  std::string where = "case";
  try {
    where = "case.method";
    e.info.method = c.at("method").get<std::string>();
    where = "case.options";
    if (c.contains("options"))
      for (auto it = c["options"].begin(); it != c["options"].end(); ++it) e.info.options[it.key()] = it->get<std::string>();
    where = "case.receiver";
    e.info.receiver = c.at("receiver").get<size_t>();
    where = "case.light";
    e.info.light = c.at("light").get<size_t>();
    where = "case.sample";
    e.info.sample = c.at("sample").get<long>();
    where = "case.tau";
    e.info.tau = c.value("tau", 1e-5);
    where = "case.expected";
    std::string ex = c.at("expected").get<std::string>();
    if (ex != "blocked" && ex != "visible") throw std::runtime_error("expected \"blocked\" or \"visible\"");
    e.info.expected = ex == "blocked" ? 'b' : 'v';
    e.info.method_visible = c.value("method_answer", "") == "visible";
    e.info.margin = c.value("margin", 0.0);
    e.info.direction = c.value("direction", "");
    e.info.class_name = c.value("class", "other");
    where = "case.status";
    e.info.status = c.at("status").get<std::string>();
    if (e.info.status != "open" && e.info.status != "fixed") throw std::runtime_error("expected \"open\" or \"fixed\"");
    e.info.note = c.value("note", "");
    if (c.contains("provenance")) {
      const auto& p = c["provenance"];
      e.info.family = p.value("family", "");
      e.info.seed = p.value("seed", uint64_t(0));
      e.info.source_scene = p.value("scene", "");
      e.info.source_receiver = p.value("receiver", size_t(0));
      e.info.source_light = p.value("light", size_t(0));
      e.info.source_sample = p.value("sample", 0L);
      e.info.source_triangles = p.value("triangles", size_t(0));
      e.info.tool = p.value("tool", "");
    }
  } catch (const std::exception& ex) {
    return Error{path + ": " + where + ": " + ex.what()};
  }
  if (e.info.receiver >= e.scene.receivers.size() || e.info.light >= e.scene.lights.size() || e.info.sample < 0 ||
      e.info.sample >= e.scene.lights[e.info.light].samples)
    return Error{path + ": case: relation (" + std::to_string(e.info.receiver) + ", " + std::to_string(e.info.light) +
                 ", " + std::to_string(e.info.sample) + ") is not in the scene"};
  return e;
}

std::vector<std::string> list_corpus(const std::string& root) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return out;
  fs::path fuzz = fs::path(root) / "fuzz";
  for (auto it = fs::recursive_directory_iterator(root, ec); it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) break;
    if (it->is_directory() && it->path() == fuzz) {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file() && it->path().extension() == ".json") out.push_back(it->path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

ReplayResult replay_entry(const CorpusEntry& e) {
  ReplayResult r;
  auto names = solver_names();
  if (std::find(names.begin(), names.end(), e.info.method) == names.end()) {
    r.registered = false;
    r.message = "method " + e.info.method + " is not built in";
    return r;
  }
  CaseSpec spec;
  spec.method = e.info.method;
  spec.options.opts = e.info.options;
  spec.receiver = e.info.receiver;
  spec.light = e.info.light;
  spec.sample = e.info.sample;
  spec.tau = e.info.tau;
  auto v = judge_relation(e.scene, spec);
  if (!v) {
    r.message = v.error().message;
    return r;
  }
  r.exact = char(v->exact);
  r.margin = v->margin;
  r.disagrees = !v->direction.empty();
  if (r.exact != e.info.expected) {
    r.message = e.path + ": the oracle now answers '" + std::string(1, r.exact) + "', the entry expects '" +
                std::string(1, e.info.expected) + "'";
    return r;
  }
  if (e.info.status == "fixed") {
    r.ok = !r.disagrees;
    if (!r.ok)
      r.message = e.path + ": regression: fixed case fails again (" + e.info.method + " answers " +
                  (v->method_visible ? "visible" : "blocked") + ", exact " + std::string(1, r.exact) + ")";
  } else {
    r.ok = r.disagrees;
    if (!r.ok)
      r.message = e.path + ": open case now passes: " + e.info.method +
                  " answers correctly; switch its status to \"fixed\"";
  }
  return r;
}

}  // namespace visgate::harness
