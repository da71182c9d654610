// Leaf relations (paper 000 section 4.10, CAST-SHADOW-RAYS): Embree leaf rays through
// the verified scene of lib/raycast/embree_scene.h, 16 per packet, or the custom ray
// caster over the shaft's blockers.
#include <algorithm>

#include "lib/iss/iss_solver.h"
#include "lib/iss/traversal.h"

namespace visgate::iss {

// CAST-SHADOW-RAYS. With the custom caster (section 4.10) the shaft's blockers, the
// leaf nodes' inside triangles (Figure 4.35) and, in pre-traversal, the pruned
// triangle list decide the ray.
void Traversal::cast_rays(int r, int l, const Shaft* sh, const std::vector<uint32_t>* tris) {
  ScopedTimer t(times_[kRays]);
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  if (!p_.custom_rays && p_.ray_queue && L.size() < kFanWidth) {
    queue_rays(r, l);
    return;
  }
  const auto& ro = rtree_->order();
  const auto& lo = ltree_->order();
  size_t blocked = 0;
  for (uint32_t a = R.begin; a < R.end; ++a) {
    uint32_t i = ro[a];
    if (p_.custom_rays) {
      ReceiverResult& rr = result_.receivers[i];
      const Vec3f& rp = scene_.receivers[i].p;
      for (uint32_t b = L.begin; b < L.end; ++b) {
        int j = int(lo[b]);
        bool occ = custom_occluded(rp, sample_position(*light_, j, i), R, L, sh, tris);
        rr.set_visible(light_offset_ + size_t(j), !occ);
        n_rays_blocked_ += occ;
      }
      continue;
    }
    fan_rays(i, lo.data() + L.begin, L.size());
  }
  n_rays_ += double(R.size()) * double(L.size());
  n_rays_blocked_ += double(blocked);
}

// The standard caster: the receiver's segments to the samples form a coherent fan,
// traced kFanWidth at a time as one Embree packet (occluded_fan).
void Traversal::fan_rays(uint32_t i, const uint32_t* samples, size_t count) {
  ReceiverResult& rr = result_.receivers[i];
  const Vec3f& rp = scene_.receivers[i].p;
  const uint64_t prefix = relation_hash_prefix(i, light_->seed);
  size_t blocked = 0;
  for (size_t b0 = 0; b0 < count; b0 += kFanWidth) {
    int n = int(std::min<size_t>(kFanWidth, count - b0));
    Vec3f to[kFanWidth];
    bool occ[kFanWidth];
    for (int k = 0; k < n; ++k) to[k] = leaf_sample_at(*light_, int(samples[b0 + size_t(k)]), prefix);
    embree_->occluded_fan(rp, to, n, occ);
    for (int k = 0; k < n; ++k) {
      // Bits start blocked (make_empty_result): only visible ones are written.
      if (!occ[k]) rr.set_visible(light_offset_ + size_t(samples[b0 + size_t(k)]), true);
      blocked += occ[k];
    }
  }
  n_rays_blocked_ += double(blocked);
}

void Traversal::queue_rays(int r, int l) {
  const TreeNode& L = ln(l);
  PendingRays& p = pending_[r];
  p.ranges.emplace_back(L.begin, L.end);
  p.samples += L.size();
  n_rays_ += double(rn(r).size()) * double(L.size());
  if (p.samples >= kFanWidth) flush_rays(r);
}

void Traversal::flush_rays(int r) {
  auto it = pending_.find(r);
  if (it == pending_.end()) return;
  const auto& lo = ltree_->order();
  pending_samples_.clear();
  for (auto [b, e] : it->second.ranges) pending_samples_.insert(pending_samples_.end(), lo.begin() + b, lo.begin() + e);
  pending_.erase(it);
  const TreeNode& R = rn(r);
  const auto& ro = rtree_->order();
  for (uint32_t a = R.begin; a < R.end; ++a) fan_rays(ro[a], pending_samples_.data(), pending_samples_.size());
}

void Traversal::flush_all_rays() {
  ScopedTimer t(times_[kRays]);
  while (!pending_.empty()) flush_rays(pending_.begin()->first);
}

bool Traversal::custom_occluded(const Vec3f& rpf, const Vec3f& lpf, const TreeNode& R, const TreeNode& L, const Shaft* sh,
                     const std::vector<uint32_t>* tris) {
  Vec3d rp = to_double(rpf), lp = to_double(lpf);
  auto hits = [&](uint32_t t) {
    return segment_hits_triangle_d(rp, lp, to_double(mesh_.corner(t, 0)), to_double(mesh_.corner(t, 1)),
                                   to_double(mesh_.corner(t, 2)));
  };
  if (!sh) {
    for (uint32_t t : *tris)
      if (hits(t)) return true;
    return false;
  }
  for (uint32_t t : R.inside)
    if (hits(t)) return true;
  for (uint32_t t : L.inside)
    if (hits(t)) return true;
  // BLOCKS-RAY clamps a surface's boundary to the segment's extent on the main axis.
  // Rays of the shaft start and end inside the node boxes, not on the clip planes (the
  // boxes' outer faces), so a surface may reach past an endpoint's level; clamping then
  // flattens that part onto the endpoint's plane, right at the endpoint, where the
  // winding's signs are decided by rounding. A surface entirely beyond an endpoint's
  // level cannot meet the segment (one
  // touching that level can meet it only at the endpoint, which does not block); one
  // reaching past it is left to the ray.
  const int ax = sh->g.main_axis();
  const double lo = std::min(rp[ax], lp[ax]), hi = std::max(rp[ax], lp[ax]);
  for (const Surface& s : sh->surfaces) {
    // Where the triangles are is the hull's to say; a boundary missing the slab while
    // the hull does not (a merged or collapsed patch, Surface::hull) leaves the ray.
    if (misses_slab(s.hull, ax, lo, hi, lo < hi)) continue;
    if (misses_slab(s.box, ax, lo, hi, lo < hi) || s.box.lo[ax] < lo || s.box.hi[ax] > hi) {
      ++n_fallback_;
      return embree_->occluded(rpf, lpf);
    }
    if (blocks_ray(ctx_, s, ax, rp, lp)) return true;
  }
  for (const AABBd& gb : sh->ghosts) {
    if (segment_may_hit_box(rp, lp, gb, 0x1p-40 * scale_)) {
      ++n_fallback_;
      return embree_->occluded(rpf, lpf);
    }
  }
  return false;
}

}  // namespace visgate::iss
