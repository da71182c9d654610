// The public API's methods (include/visgate/visgate.h, target visgate::methods).
#include <exception>

#include "lib/api/api_internal.h"
#include "lib/external/external_methods.h"

namespace visgate::api {

std::vector<std::string> method_names() { return solver_names(); }

Outcome<Solution> solve(const Scene& scene, const std::string& method, const SolveSettings& settings) {
  using O = Outcome<Solution>;
  auto solver = make_solver(method);
  if (!solver) return O::failure(external::describe_unknown_method(method));
  SolveOptions so;
  so.opts = settings.options;
  so.threads = settings.threads;
  so.seed = settings.seed;
  Status st = solver->check_options(so);
  if (!st) return O::failure(st.error().message);
  const visgate::Scene& s = scene.impl();
  SolveResult r;
  try {
    ThreadLimit limit(settings.threads);
    r = solver->solve(s, so);
  } catch (const std::exception& e) {  // an external method's failure
    return O::failure(e.what());
  }
  Solution out;
  out.method = method;
  out.receivers = s.receivers.size();
  out.relations_per_receiver = s.samples_per_receiver();
  out.lights = s.lights.size();
  out.visible.resize(out.receivers * out.relations_per_receiver);
  out.visible_fraction.resize(out.receivers * out.lights);
  for (size_t i = 0; i < out.receivers; ++i) {
    const ReceiverResult& rr = r.receivers[i];
    for (size_t b = 0; b < out.relations_per_receiver; ++b) out.visible[i * out.relations_per_receiver + b] = rr.visible(b);
    for (size_t l = 0; l < out.lights; ++l) out.visible_fraction[i * out.lights + l] = rr.visible_fraction[l];
  }
  if (solver->reports_fragments()) {
    out.fragments.resize(out.receivers);
    for (size_t i = 0; i < out.receivers; ++i)
      for (const auto& per_light : r.receivers[i].fragments) {
        std::vector<Polygon> polys;
        for (const auto& poly : per_light) {
          Polygon p;
          for (const auto& v : poly) p.push_back(detail::to_api(v));
          polys.push_back(std::move(p));
        }
        out.fragments[i].push_back(std::move(polys));
      }
  }
  for (const auto& [k, v] : r.stats.sorted()) out.stats[std::string(k)] = v;
  out.seconds = r.seconds;
  return out;
}

namespace detail {

SolveResult to_solve_result(const visgate::Scene& scene, const Solution& s) {
  SolveResult r = make_empty_result(scene);
  for (size_t i = 0; i < r.receivers.size() && i < s.receivers; ++i) {
    for (size_t b = 0; b < s.relations_per_receiver; ++b) r.receivers[i].set_visible(b, s.is_visible(i, b));
    for (size_t l = 0; l < s.lights; ++l) r.receivers[i].visible_fraction[l] = s.fraction(i, l);
    if (i < s.fragments.size()) {
      r.receivers[i].fragments.resize(s.fragments[i].size());
      for (size_t l = 0; l < s.fragments[i].size(); ++l)
        for (const auto& poly : s.fragments[i][l]) {
          Polygon3f p;
          for (const auto& v : poly) p.push_back(from_api(v));
          r.receivers[i].fragments[l].push_back(std::move(p));
        }
    }
  }
  return r;
}

}  // namespace detail
}  // namespace visgate::api
