// Oracle JSON writer and reader (DESIGN section 5); layout in oracle_json.h.
#include "oracle/oracle_json.h"

#include <cstdlib>
#include <nlohmann/json.hpp>

#include "lib/scene/float_text.h"

namespace visgate::oracle {

namespace {
// A float as the double whose shortest round-trip text is its 9-digit decimal, so
// nlohmann writes that text and strtof reads the float back.
double float_json(float f) { return std::strtod(float_to_decimal(f).c_str(), nullptr); }
}  // namespace

std::string write_oracle_json(const Scene& scene, const RelationOracleResult& relations,
                              const std::vector<std::vector<RegionAnswer>>& regions, double tau) {
  using json = nlohmann::ordered_json;
  json doc;
  doc["format"] = "visgate-oracle";
  doc["version"] = 1;
  doc["tau"] = tau;
  doc["scene"] = scene.name;
  doc["seconds"] = relations.seconds;
  json recs = json::array();
  for (size_t i = 0; i < scene.receivers.size(); ++i) {
    json r;
    r["classes"] = i < relations.classes.size() ? relations.classes[i] : std::string();
    json m = json::array();
    if (i < relations.margins.size())
      for (double x : relations.margins[i]) m.push_back(x);
    r["margins"] = m;
    if (i < regions.size()) {
      json rg = json::array();
      for (size_t l = 0; l < regions[i].size(); ++l) {
        const RegionAnswer& a = regions[i][l];
        json e;
        e["light"] = l;
        e["visible_fraction"] = a.visible_fraction;
        json polys = json::array();
        for (const auto& poly : a.polygons) {
          json pj = json::array();
          for (const Vec3f& p : poly) pj.push_back({float_json(p.x), float_json(p.y), float_json(p.z)});
          polys.push_back(pj);
        }
        e["polygons"] = polys;
        json holes = json::array();
        for (bool h : a.hole) holes.push_back(h);
        e["holes"] = holes;
        e["irradiance"] = a.irradiance;
        e["edge_on"] = a.edge_on;
        rg.push_back(std::move(e));
      }
      r["regions"] = rg;
    }
    recs.push_back(std::move(r));
  }
  doc["receivers"] = std::move(recs);
  return doc.dump() + "\n";
}

Result<OracleFile> read_oracle_json(const std::string& text, const std::string& origin) {
  // Plain double parsing (margins are doubles; parse_json_exact would round them to float).
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded()) return Error{origin + ": not valid JSON"};
  if (!doc.is_object() || doc.value("format", std::string()) != "visgate-oracle")
    return Error{origin + ": format: expected \"visgate-oracle\""};
  if (!doc.contains("version") || !doc["version"].is_number_integer() || doc["version"].get<int>() != 1)
    return Error{origin + ": version: expected 1"};
  OracleFile f;
  if (doc.contains("tau")) {
    if (!doc["tau"].is_number()) return Error{origin + ": tau: expected a number"};
    f.tau = doc["tau"].get<double>();
  }
  if (!doc.contains("receivers") || !doc["receivers"].is_array()) return Error{origin + ": receivers: expected an array"};
  const auto& recs = doc["receivers"];
  for (size_t i = 0; i < recs.size(); ++i) {
    std::string where = origin + ": receivers[" + std::to_string(i) + "]";
    const auto& r = recs[i];
    if (!r.is_object() || !r.contains("classes") || !r["classes"].is_string())
      return Error{where + ".classes: expected a string"};
    std::string cls = r["classes"].get<std::string>();
    for (char ch : cls)
      if (ch != 'v' && ch != 'b' && ch != 'd') return Error{where + ".classes: unexpected character"};
    if (!r.contains("margins") || !r["margins"].is_array() || r["margins"].size() != cls.size())
      return Error{where + ".margins: expected an array parallel to classes"};
    std::vector<double> m;
    for (size_t k = 0; k < cls.size(); ++k) {
      if (!r["margins"][k].is_number()) return Error{where + ".margins[" + std::to_string(k) + "]: expected a number"};
      m.push_back(r["margins"][k].get<double>());
    }
    f.relations.classes.push_back(std::move(cls));
    f.relations.margins.push_back(std::move(m));
  }
  return f;
}

}  // namespace visgate::oracle
