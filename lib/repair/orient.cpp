// The orient pass of repair_mesh (see passes.h).
#include <utility>

#include "lib/repair/nesting.h"
#include "lib/repair/passes.h"

namespace visgate::mesh {

// Consistent orientation per patch (faces joined across two-face edges), flipping the
// minority; closed patches then bound the solid: outward by the exact volume sign, or
// inward where nesting makes them a cavity.
OrientCounts orient(Work& w, const ExactPredicates& ex) {
  OrientCounts st;
  const size_t nt = w.tris.size();
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  Adjacency adj = build_adjacency(e, nt);
  std::vector<int8_t> parity(nt, -1);
  std::vector<uint32_t> patch;
  std::vector<std::vector<uint32_t>> closed_patches;
  for (uint32_t s = 0; s < nt; ++s) {
    if (parity[s] >= 0) continue;
    parity[s] = 0;
    patch.assign(1, s);
    bool conflict = false, closed = true;
    for (size_t qi = 0; qi < patch.size(); ++qi) {
      uint32_t t = patch[qi];
      for (int k = 0; k < 3; ++k) {
        uint32_t u = adj.nb[3 * size_t(t) + size_t(k)];
        if (u == kNone) { closed = false; continue; }
        int8_t want = int8_t(parity[t] ^ adj.same[3 * size_t(t) + size_t(k)]);
        if (parity[u] < 0) {
          parity[u] = want;
          patch.push_back(u);
        } else if (parity[u] != want) {
          conflict = true;
        }
      }
    }
    if (conflict) {  // non-orientable: leave it as it is, reported by the analysis
      ++st.nonorientable_skipped;
      continue;
    }
    size_t ones = 0;
    for (uint32_t t : patch) ones += size_t(parity[t]);
    int8_t flip_if = ones * 2 > patch.size() ? 0 : 1;
    for (uint32_t t : patch)
      if (parity[t] == flip_if) {
        std::swap(w.tris[t][1], w.tris[t][2]);
        ++st.consistency_flips;
      }
    if (closed) closed_patches.push_back(patch);
  }
  // Closed patches face outward, or inward where they bound a cavity (nesting parity).
  std::vector<std::vector<uint32_t>> shells;
  std::vector<int> sign;
  for (auto& p : closed_patches) {
    const int s = ex.volume_sign(w.pos, w.tris, p);
    if (s == 0) continue;
    shells.push_back(std::move(p));
    sign.push_back(s);
  }
  const std::vector<int> depth = nesting_depths(w.pos, w.tris, shells, FilteredPredicates(ex));
  for (size_t i = 0; i < shells.size(); ++i) {
    if (depth[i] % 2 == 1) ++st.cavities;
    if (sign[i] == (depth[i] % 2 == 1 ? -1 : 1)) continue;
    for (uint32_t t : shells[i]) std::swap(w.tris[t][1], w.tris[t][2]);
    ++st.outward_components;
    st.outward_flips += shells[i].size();
  }
  return st;
}

StepRecord OrientCounts::record(double seconds) const {
  return {"orient",
          {{"faces_flipped_for_consistency", consistency_flips},
           {"components_turned_outward", outward_components},
           {"faces_flipped_outward", outward_flips},
           {"cavities", cavities},
           {"nonorientable_patches_left", nonorientable_skipped}},
          seconds};
}

}  // namespace visgate::mesh
