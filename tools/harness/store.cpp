// Turning a mismatch into a stored corpus case (see store.h).
#include "tools/harness/store.h"

#include <cstdio>

#include "lib/scene/families.h"

namespace visgate::harness {

std::string family_from_scene_name(const std::string& name) {
  std::string best = "other";
  for (const auto& f : family_names())
    if (name.rfind(f, 0) == 0 && (name.size() == f.size() || name[f.size()] == '-') &&
        (best == "other" || f.size() > best.size()))
      best = f;
  return best;
}

Result<StoredCase> minimize_and_store(const Scene& scene, const CaseSpec& spec, const CaseInfo& base,
                                      const std::string& root) {
  auto m = minimize_case(scene, spec);
  if (!m) return m.error();
  StoredCase out;
  CaseInfo info = base;
  info.method = spec.method;
  info.options = spec.options.opts;
  info.receiver = m->receiver;
  info.light = m->light;
  info.sample = m->sample;
  info.tau = spec.tau;
  info.expected = char(m->verdict.exact);
  info.method_visible = m->verdict.method_visible;
  info.margin = m->verdict.margin;
  info.direction = m->verdict.direction;
  info.class_name = classify_case(m->scene, m->receiver, m->light, m->sample, info.family);
  if (info.note.empty()) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s answers %s where the segment is exactly %s (margin %.3g); minimised from %s receiver %zu light "
                  "%zu sample %ld (%zu triangles)",
                  spec.method.c_str(), info.method_visible ? "visible" : "blocked",
                  info.expected == 'b' ? "blocked" : "visible", info.margin, info.source_scene.c_str(),
                  info.source_receiver, info.source_light, info.source_sample, info.source_triangles);
    info.note = buf;
  }
  auto path = write_corpus_entry(root, m->scene, info);
  if (!path) return path.error();
  out.path = *path;
  out.info = info;
  out.minimized = std::move(*m);
  return out;
}

}  // namespace visgate::harness
