// Scene JSON reader and writer (DESIGN section 6); see scene_json.h.
#include "lib/scene/scene_json.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "lib/scene/float_text.h"
#include "lib/scene/json_exact.h"
#include "lib/scene/mesh_io.h"

namespace visgate {

namespace {

using json = nlohmann::json;

// Reader context: carries the file name for messages and turns the first error into a
// short-circuiting failure.
struct Reader {
  std::string origin;
  std::string error;

  bool fail(const std::string& where, const std::string& what) {
    if (error.empty()) error = origin + ": " + where + ": " + what;
    return false;
  }

  bool get_float(const json& v, const std::string& where, float& out) {
    if (v.is_number()) {
      out = v.is_number_float() ? float(v.get<double>())
                                : (v.is_number_unsigned() ? float(v.get<uint64_t>()) : float(v.get<int64_t>()));
    } else if (v.is_string()) {
      auto f = parse_float(v.get<std::string>());
      if (!f) return fail(where, "not a number: \"" + v.get<std::string>().substr(0, 40) + "\"");
      out = *f;
    } else {
      return fail(where, "expected a number");
    }
    if (!std::isfinite(out)) return fail(where, "coordinate is NaN or infinite");
    return true;
  }

  bool get_vec(const json& v, const std::string& where, Vec3f& out) {
    if (!v.is_array() || v.size() != 3) return fail(where, "expected [x, y, z]");
    for (int k = 0; k < 3; ++k)
      if (!get_float(v[k], where + "[" + std::to_string(k) + "]", out[k])) return false;
    return true;
  }

  bool get_int(const json& obj, const char* key, const std::string& where, int64_t lo, int64_t hi, int64_t& out) {
    if (!obj.contains(key)) return true;  // keep default
    const json& v = obj[key];
    if (!v.is_number_integer()) return fail(where + "." + key, "expected an integer");
    if (v.is_number_unsigned() && v.get<uint64_t>() > uint64_t(INT64_MAX)) return fail(where + "." + key, "out of range");
    int64_t x = v.get<int64_t>();
    if (x < lo || x > hi)
      return fail(where + "." + key, std::to_string(x) + " out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = x;
    return true;
  }

  bool get_vec_list(const json& v, const std::string& where, std::vector<Vec3f>& out, size_t limit) {
    if (!v.is_array()) return fail(where, "expected an array of [x, y, z]");
    if (v.size() > limit) return fail(where, std::to_string(v.size()) + " entries exceed the limit " + std::to_string(limit));
    out.resize(v.size());
    for (size_t i = 0; i < v.size(); ++i)
      if (!get_vec(v[i], where + "[" + std::to_string(i) + "]", out[i])) return false;
    return true;
  }
};

}  // namespace

Result<Scene> read_scene_file(const std::string& path, const SceneLimits& limits) {
  auto text = read_text_file(path);
  if (!text) return text.error();
  std::string base = std::filesystem::path(path).parent_path().string();
  return read_scene_json(*text, path, base, limits);
}

Result<Scene> read_scene_json(const std::string& text, const std::string& origin, const std::string& base_dir,
                              const SceneLimits& limits) {
  auto parsed = parse_json_exact(text, origin);
  if (!parsed) return parsed.error();
  const json& doc = *parsed;
  Reader rd{origin, {}};
  auto err = [&]() -> Result<Scene> { return Error{rd.error}; };

  if (!doc.is_object()) { rd.fail("document", "expected a JSON object"); return err(); }
  if (!doc.contains("format") || doc["format"] != "visgate-scene") { rd.fail("format", "expected \"visgate-scene\""); return err(); }
  if (!doc.contains("version") || doc["version"] != 1) { rd.fail("version", "expected 1"); return err(); }

  Scene scene;
  if (doc.contains("name")) {
    if (!doc["name"].is_string()) { rd.fail("name", "expected a string"); return err(); }
    scene.name = doc["name"].get<std::string>();
  }

  // Meshes.
  if (doc.contains("meshes")) {
    const json& meshes = doc["meshes"];
    if (!meshes.is_array()) { rd.fail("meshes", "expected an array"); return err(); }
    for (size_t m = 0; m < meshes.size(); ++m) {
      std::string where = "meshes[" + std::to_string(m) + "]";
      const json& mj = meshes[m];
      if (!mj.is_object()) { rd.fail(where, "expected an object"); return err(); }
      TriangleSoup soup;
      if (mj.contains("file")) {
        if (!mj["file"].is_string()) { rd.fail(where + ".file", "expected a string"); return err(); }
        std::filesystem::path p(mj["file"].get<std::string>());
        if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
        auto poly = read_polygon_file(p.string());
        if (!poly) return Error{origin + ": " + where + ".file: " + poly.error().message};
        size_t shorts = 0;
        auto tri = triangulate(*poly, p.string(), &shorts);
        if (!tri) return Error{origin + ": " + where + ".file: " + tri.error().message};
        if (shorts) return Error{origin + ": " + where + ".file: " + p.string() + ": " + std::to_string(shorts) + " faces with fewer than 3 vertices"};
        soup = std::move(*tri);
      } else {
        if (!mj.contains("vertices") || !mj.contains("triangles")) { rd.fail(where, "needs \"file\" or \"vertices\" and \"triangles\""); return err(); }
        if (!rd.get_vec_list(mj["vertices"], where + ".vertices", soup.vertices, limits.max_triangles * 3)) return err();
        const json& tj = mj["triangles"];
        if (!tj.is_array()) { rd.fail(where + ".triangles", "expected an array of [a, b, c]"); return err(); }
        if (tj.size() > limits.max_triangles) { rd.fail(where + ".triangles", std::to_string(tj.size()) + " triangles exceed the limit " + std::to_string(limits.max_triangles)); return err(); }
        soup.triangles.resize(tj.size());
        for (size_t t = 0; t < tj.size(); ++t) {
          std::string tw = where + ".triangles[" + std::to_string(t) + "]";
          if (!tj[t].is_array() || tj[t].size() != 3) { rd.fail(tw, "expected [a, b, c]"); return err(); }
          for (int k = 0; k < 3; ++k) {
            const json& ij = tj[t][k];
            if (!ij.is_number_integer() || (ij.is_number_integer() && !ij.is_number_unsigned() && ij.get<int64_t>() < 0) ||
                ij.get<uint64_t>() >= soup.vertices.size()) {
              rd.fail(tw + "[" + std::to_string(k) + "]", "vertex index out of range (" + std::to_string(soup.vertices.size()) + " vertices)");
              return err();
            }
            soup.triangles[t][k] = uint32_t(ij.get<uint64_t>());
          }
        }
      }
      scene.mesh.append(soup);
      if (scene.mesh.size() > limits.max_triangles) { rd.fail(where, "triangle count exceeds the limit " + std::to_string(limits.max_triangles)); return err(); }
    }
  }

  // Lights.
  if (!doc.contains("lights") || !doc["lights"].is_array() || doc["lights"].empty()) { rd.fail("lights", "expected a non-empty array"); return err(); }
  for (size_t l = 0; l < doc["lights"].size(); ++l) {
    std::string where = "lights[" + std::to_string(l) + "]";
    const json& lj = doc["lights"][l];
    if (!lj.is_object()) { rd.fail(where, "expected an object"); return err(); }
    Light light;
    if (!lj.contains("polygon")) { rd.fail(where + ".polygon", "missing"); return err(); }
    if (!rd.get_vec_list(lj["polygon"], where + ".polygon", light.polygon, 1024)) return err();
    int64_t samples = light.samples, jitter = light.jitter, seed = int64_t(light.seed);
    if (!rd.get_int(lj, "samples", where, 1, 1 << 20, samples)) return err();
    if (!rd.get_int(lj, "jitter", where, 1, 64, jitter)) return err();
    if (lj.contains("seed")) {
      if (!lj["seed"].is_number_integer()) { rd.fail(where + ".seed", "expected an integer"); return err(); }
      light.seed = lj["seed"].is_number_unsigned() ? lj["seed"].get<uint64_t>() : uint64_t(lj["seed"].get<int64_t>());
    } else {
      light.seed = uint64_t(seed);
    }
    // Lights with more samples in total than the relation limit can never fit; checked
    // before prepare_light allocates samples * jitter points (fuzz_scene_json: a 160-byte
    // file otherwise costs 800 MB and a minute under small limits).
    if (uint64_t(samples) + scene.samples_per_receiver() > limits.max_relations) { rd.fail(where + ".samples", std::to_string(samples) + " samples exceed the relation limit " + std::to_string(limits.max_relations)); return err(); }
    light.samples = int(samples);
    light.jitter = int(jitter);
    if (lj.contains("pattern")) {
      std::string p = lj["pattern"].is_string() ? lj["pattern"].get<std::string>() : "";
      if (p == "stratified") light.pattern = SamplePattern::Stratified;
      else if (p == "random") light.pattern = SamplePattern::Random;
      else if (p == "grid") light.pattern = SamplePattern::Grid;
      else if (p == "explicit") light.pattern = SamplePattern::Explicit;
      else { rd.fail(where + ".pattern", "expected \"stratified\", \"random\", \"grid\" or \"explicit\""); return err(); }
    }
    if (lj.contains("explicit_samples")) {
      if (!rd.get_vec_list(lj["explicit_samples"], where + ".explicit_samples", light.explicit_samples, 1 << 20)) return err();
      light.pattern = SamplePattern::Explicit;
    }
    Status st = prepare_light(light, origin + ": " + where);
    if (!st) return st.error();
    scene.lights.push_back(std::move(light));
  }

  // Receivers.
  if (!doc.contains("receivers")) { rd.fail("receivers", "missing"); return err(); }
  const json& rj = doc["receivers"];
  if (rj.is_object()) {
    if (!rj.contains("grid") || !rj["grid"].is_object()) { rd.fail("receivers", "expected a list or {\"grid\": {...}}"); return err(); }
    const json& g = rj["grid"];
    ReceiverGrid grid;
    for (const char* key : {"origin", "u", "v"}) {
      if (!g.contains(key)) { rd.fail(std::string("receivers.grid.") + key, "missing"); return err(); }
    }
    if (!rd.get_vec(g["origin"], "receivers.grid.origin", grid.origin)) return err();
    if (!rd.get_vec(g["u"], "receivers.grid.u", grid.u)) return err();
    if (!rd.get_vec(g["v"], "receivers.grid.v", grid.v)) return err();
    if (g.contains("normal") && !rd.get_vec(g["normal"], "receivers.grid.normal", grid.normal)) return err();
    if (g.contains("offset") && !rd.get_float(g["offset"], "receivers.grid.offset", grid.offset)) return err();
    int64_t nu = 0, nv = 0;
    if (!g.contains("nu") || !g.contains("nv")) { rd.fail("receivers.grid", "needs nu and nv"); return err(); }
    if (!rd.get_int(g, "nu", "receivers.grid", 1, 1 << 24, nu)) return err();
    if (!rd.get_int(g, "nv", "receivers.grid", 1, 1 << 24, nv)) return err();
    if (uint64_t(nu) * uint64_t(nv) > limits.max_receivers) { rd.fail("receivers.grid", std::to_string(nu * nv) + " receivers exceed the limit " + std::to_string(limits.max_receivers)); return err(); }
    grid.nu = int(nu);
    grid.nv = int(nv);
    scene.receivers = grid_receivers(grid);
    for (size_t i = 0; i < scene.receivers.size(); ++i)
      if (!is_finite(scene.receivers[i].p)) { rd.fail("receivers.grid", "receiver " + std::to_string(i) + " overflows float32"); return err(); }
    scene.grid = grid;
  } else if (rj.is_array()) {
    if (rj.size() > limits.max_receivers) { rd.fail("receivers", std::to_string(rj.size()) + " receivers exceed the limit " + std::to_string(limits.max_receivers)); return err(); }
    scene.receivers.resize(rj.size());
    for (size_t i = 0; i < rj.size(); ++i) {
      std::string where = "receivers[" + std::to_string(i) + "]";
      if (!rj[i].is_object() || !rj[i].contains("p")) { rd.fail(where, "expected {\"p\": [x,y,z], \"n\": [x,y,z]}"); return err(); }
      if (!rd.get_vec(rj[i]["p"], where + ".p", scene.receivers[i].p)) return err();
      if (rj[i].contains("n") && !rd.get_vec(rj[i]["n"], where + ".n", scene.receivers[i].n)) return err();
    }
  } else {
    rd.fail("receivers", "expected a list or {\"grid\": {...}}");
    return err();
  }
  if (scene.relation_count() > limits.max_relations) {
    rd.fail("receivers", std::to_string(scene.relation_count()) + " relations exceed the limit");
    return err();
  }
  return scene;
}

namespace {

struct Writer {
  bool hex;
  std::ostringstream out;
  void num(float f) {
    if (hex) out << '"' << float_to_hex(f) << '"';
    else out << float_to_decimal(f);
  }
  void vec(const Vec3f& v) {
    out << '[';
    num(v.x); out << ',';
    num(v.y); out << ',';
    num(v.z); out << ']';
  }
  void vec_list(const std::vector<Vec3f>& vs) {
    out << '[';
    for (size_t i = 0; i < vs.size(); ++i) {
      if (i) out << ',';
      vec(vs[i]);
    }
    out << ']';
  }
};

const char* pattern_name(SamplePattern p) {
  switch (p) {
    case SamplePattern::Random: return "random";
    case SamplePattern::Grid: return "grid";
    case SamplePattern::Explicit: return "explicit";
    default: return "stratified";
  }
}

}  // namespace

std::string write_scene_json(const Scene& scene, const SceneWriteOptions& opt) {
  Writer w{opt.hex, {}};
  auto& o = w.out;
  o << "{\"format\":\"visgate-scene\",\"version\":1,\"name\":" << json(scene.name).dump() << ",\n";
  o << "\"meshes\":[{\"vertices\":";
  w.vec_list(scene.mesh.vertices);
  o << ",\n\"triangles\":[";
  for (size_t t = 0; t < scene.mesh.triangles.size(); ++t) {
    const auto& tr = scene.mesh.triangles[t];
    o << (t ? "," : "") << '[' << tr[0] << ',' << tr[1] << ',' << tr[2] << ']';
  }
  o << "]}],\n\"lights\":[";
  for (size_t l = 0; l < scene.lights.size(); ++l) {
    const Light& L = scene.lights[l];
    o << (l ? ",\n" : "") << "{\"polygon\":";
    w.vec_list(L.polygon);
    o << ",\"samples\":" << L.samples << ",\"pattern\":\"" << pattern_name(L.pattern) << "\",\"jitter\":" << L.jitter
      << ",\"seed\":" << L.seed;
    if (L.pattern == SamplePattern::Explicit) {
      o << ",\"explicit_samples\":";
      w.vec_list(L.explicit_samples);
    }
    if (opt.relation_points && !(L.pattern == SamplePattern::Explicit && L.jitter == 1)) {
      o << ",\n\"relation_points\":[";
      for (size_t i = 0; i < scene.receivers.size(); ++i) {
        o << (i ? ",\n[" : "[");
        for (int j = 0; j < L.samples; ++j) {
          if (j) o << ',';
          w.vec(sample_position(L, j, i));
        }
        o << ']';
      }
      o << ']';
    }
    o << '}';
  }
  o << "],\n\"receivers\":";
  if (scene.grid && !opt.relation_points) {
    const ReceiverGrid& g = *scene.grid;
    o << "{\"grid\":{\"origin\":";
    w.vec(g.origin);
    o << ",\"u\":";
    w.vec(g.u);
    o << ",\"v\":";
    w.vec(g.v);
    o << ",\"nu\":" << g.nu << ",\"nv\":" << g.nv << ",\"normal\":";
    w.vec(g.normal);
    o << ",\"offset\":";
    w.num(g.offset);
    o << "}}";
  } else {
    o << '[';
    for (size_t i = 0; i < scene.receivers.size(); ++i) {
      o << (i ? ",\n" : "") << "{\"p\":";
      w.vec(scene.receivers[i].p);
      o << ",\"n\":";
      w.vec(scene.receivers[i].n);
      o << '}';
    }
    o << ']';
  }
  o << "}\n";
  return o.str();
}

}  // namespace visgate
