// Tree initialisation for one group and one light (paper 002 section 4.4, Algorithm 2
// line 8: an empty BSP tree with the group's occluder set; Figure 8 column "I"): the
// occluders' vvsets (section 3.3, Theorem 1) and the receiver region's (bsp.h), and the
// root as one undefined leaf. The tree is the thread's, rebuilt per group (GroupState).
#include <algorithm>
#include <memory>

#include "lib/plucker/group_state.h"

namespace visgate::plucker {

LazyBsp& init_group_tree(GroupState& gs, ThreadWork& work, uint64_t tree_seed, Totals& tot) {
  tot.occluders += gs.occluders.size();
  tot.near += gs.near.size();
  // The receiver region for the second vvset (bsp.h): the distinct corners of the box.
  std::vector<Vec3d>& region = gs.region;
  for (const Vec3d& c : gs.corners)
    if (std::find(region.begin(), region.end(), c) == region.end()) region.push_back(c);
  if (!work.tree) work.tree = std::make_unique<LazyBsp>(nullptr, 0, std::vector<Occluder>{}, 0);
  LazyBsp& bsp = *work.tree;
  const LocalLight& lf = *gs.lf;
  bsp.rebuild(lf.poly.data(), int(lf.poly.size()), gs.occluders, tree_seed, region.data(), int(region.size()));
  bsp.set_memory_budget(gs.ctx->memory->budget);
  bsp.set_choice(gs.ctx->choice);
  bsp.set_light_plane(lf.plane);
  ++tot.trees;
  return bsp;
}

}  // namespace visgate::plucker
