// The public API's scenes (include/visgate/visgate.h, target visgate::scene).
#include <cmath>
#include <cstdint>

#include "lib/api/api_internal.h"
#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"

namespace visgate::api {

using detail::from_api;
using detail::to_api;

const std::string& Scene::name() const { return impl_->name; }
size_t Scene::triangle_count() const { return impl_->mesh.size(); }
size_t Scene::receiver_count() const { return impl_->receivers.size(); }
size_t Scene::light_count() const { return impl_->lights.size(); }
size_t Scene::relations_per_receiver() const { return impl_->samples_per_receiver(); }
size_t Scene::relation_offset(size_t light) const {
  return light >= impl_->lights.size() ? impl_->samples_per_receiver() : impl_->light_offset(light);
}
Vec3 Scene::receiver(size_t i) const { return to_api(impl_->receivers.at(i).p); }

Vec3 Scene::light_point(size_t i, size_t b) const {
  size_t l = 0;
  while (l + 1 < impl_->lights.size() && b >= impl_->light_offset(l + 1)) ++l;
  return to_api(sample_position(impl_->lights.at(l), int(b - impl_->light_offset(l)), i));
}

std::array<Vec3, 3> Scene::triangle(size_t t) const {
  return {to_api(impl_->mesh.corner(t, 0)), to_api(impl_->mesh.corner(t, 1)), to_api(impl_->mesh.corner(t, 2))};
}

std::string Scene::to_json() const { return write_scene_json(*impl_); }

Scene Scene::single_relation(size_t i, size_t b) const {
  visgate::Scene s;
  s.name = impl_->name + "-r" + std::to_string(i) + "-b" + std::to_string(b);
  s.mesh = impl_->mesh;
  s.receivers = {impl_->receivers.at(i)};
  size_t l = 0;
  while (l + 1 < impl_->lights.size() && b >= impl_->light_offset(l + 1)) ++l;
  Light L;
  L.polygon = impl_->lights.at(l).polygon;
  L.samples = 1;
  L.jitter = 1;
  L.pattern = SamplePattern::Explicit;
  L.explicit_samples = {from_api(light_point(i, b))};
  // The light was valid and the point is one of its own: preparing it cannot fail.
  Status st = prepare_light(L, "single_relation");
  VG_CHECK(st.ok());
  s.lights.push_back(std::move(L));
  return detail::wrap(std::move(s));
}

Scene Scene::with_triangles(const std::vector<bool>& keep) const {
  // The kept triangles and only the vertices they use, in their first-use order.
  visgate::Scene s = *impl_;
  s.mesh = TriangleSoup{};
  std::vector<uint32_t> index(impl_->mesh.vertices.size(), UINT32_MAX);
  for (size_t t = 0; t < impl_->mesh.size() && t < keep.size(); ++t) {
    if (!keep[t]) continue;
    std::array<uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      uint32_t& v = index[impl_->mesh.triangles[t][k]];
      if (v == UINT32_MAX) {
        v = uint32_t(s.mesh.vertices.size());
        s.mesh.vertices.push_back(impl_->mesh.corner(t, k));
      }
      tri[k] = v;
    }
    s.mesh.triangles.push_back(tri);
  }
  return detail::wrap(std::move(s));
}

Outcome<Scene> make_scene(const SceneDesc& d) {
  using O = Outcome<Scene>;
  visgate::Scene s;
  s.name = d.name;
  if (d.vertices.size() % 3 != 0) return O::failure("vertices: length " + std::to_string(d.vertices.size()) + " is not a multiple of 3");
  if (d.triangles.size() % 3 != 0) return O::failure("triangles: length " + std::to_string(d.triangles.size()) + " is not a multiple of 3");
  for (size_t k = 0; k < d.vertices.size(); k += 3) {
    const Vec3f v(d.vertices[k], d.vertices[k + 1], d.vertices[k + 2]);
    if (!is_finite(v)) return O::failure("vertices[" + std::to_string(k / 3) + "]: coordinate is NaN or infinite");
    s.mesh.vertices.push_back(v);
  }
  for (size_t k = 0; k < d.triangles.size(); k += 3) {
    for (int c = 0; c < 3; ++c)
      if (d.triangles[k + c] >= s.mesh.vertices.size())
        return O::failure("triangles[" + std::to_string(k / 3) + "][" + std::to_string(c) + "]: index " +
                          std::to_string(d.triangles[k + c]) + " is not a vertex");
    s.mesh.triangles.push_back({d.triangles[k], d.triangles[k + 1], d.triangles[k + 2]});
  }
  if (d.lights.empty()) return O::failure("lights: expected at least one light");
  for (size_t l = 0; l < d.lights.size(); ++l) {
    const LightDesc& ld = d.lights[l];
    const std::string where = "lights[" + std::to_string(l) + "]";
    if (ld.samples < 1 || ld.samples > (1 << 20)) return O::failure(where + ".samples: expected 1 to 2^20");
    if (ld.jitter < 1 || ld.jitter > 64) return O::failure(where + ".jitter: expected 1 to 64");
    Light L;
    for (const auto& p : ld.polygon) L.polygon.push_back(from_api(p));
    L.samples = ld.samples;
    L.jitter = ld.jitter;
    L.seed = ld.seed;
    L.pattern = ld.pattern == Pattern::Random     ? SamplePattern::Random
                : ld.pattern == Pattern::Grid     ? SamplePattern::Grid
                : ld.pattern == Pattern::Explicit ? SamplePattern::Explicit
                                                  : SamplePattern::Stratified;
    for (const auto& p : ld.explicit_samples) L.explicit_samples.push_back(from_api(p));
    Status st = prepare_light(L, where);
    if (!st) return O::failure(st.error().message);
    s.lights.push_back(std::move(L));
  }
  for (size_t i = 0; i < d.receivers.size(); ++i) {
    const Receiver r{from_api(d.receivers[i].p), from_api(d.receivers[i].n)};
    if (!is_finite(r.p) || !is_finite(r.n))
      return O::failure("receivers[" + std::to_string(i) + "]: coordinate is NaN or infinite");
    s.receivers.push_back(r);
  }
  return detail::wrap(std::move(s));
}

Outcome<Scene> read_scene(const std::string& path) {
  auto s = read_scene_file(path);
  if (!s) return Outcome<Scene>::failure(s.error().message);
  return detail::wrap(std::move(*s));
}

std::vector<std::string> family_names() { return visgate::family_names(); }

Outcome<Scene> generate_family(const std::string& family, uint64_t seed, long triangles, long receivers, long samples) {
  if (!is_family(family)) return Outcome<Scene>::failure("family " + family + ": unknown family");
  FamilyParams p;
  p.seed = seed;
  p.triangles = triangles;
  p.receivers = receivers;
  p.samples = samples;
  auto s = visgate::generate_family(family, p);
  if (!s) return Outcome<Scene>::failure(s.error().message);
  return detail::wrap(std::move(*s));
}

}  // namespace visgate::api
