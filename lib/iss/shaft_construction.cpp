// Shaft construction (paper 000 sections 4.7 and 4.8): CONSTRUCT-SUB-SHAFT (Figure 4.19)
// with the refinement of each surface (4.7.2-4.7.7, blockers.h), CONSTRUCT-INITIAL-SHAFT
// (Figure 4.31), the blocker probe before it, and the shaft pools of section 4.13.
#include <algorithm>
#include <array>
#include <span>

#include "lib/iss/traversal.h"

namespace visgate::iss {

// The shaft is done: its surfaces, and its two arrays, go back to the pools (section
// 4.13), so that the next shaft's arrays need no allocation.
void Traversal::release(Shaft& sh) {
  live_bytes_ -= sh.bytes;
  if (budget_) budget_->change(-int64_t(sh.bytes), "shafts");
  for (Surface& s : sh.surfaces) ws_.recycle(std::move(s));
  sh.surfaces.clear();
  sh.ghosts.clear();
  sh.band.clear();
  if (surface_lists_.size() < 256) {
    surface_lists_.push_back(std::move(sh.surfaces));
    ghost_lists_.push_back(std::move(sh.ghosts));
    band_lists_.push_back(std::move(sh.band));
  }
}

// A shaft with pooled (empty) arrays.
void Traversal::init_shaft(Shaft& sh) {
  if (surface_lists_.empty()) return;
  sh.surfaces = std::move(surface_lists_.back());
  sh.ghosts = std::move(ghost_lists_.back());
  sh.band = std::move(band_lists_.back());
  surface_lists_.pop_back();
  ghost_lists_.pop_back();
  band_lists_.pop_back();
}

// ---- section 4.7: sub-shaft construction ---------------------------------------------
// Lines 14-18 of Figure 4.19 for one surface. `settled`: the surface is as the parent
// shaft's construction left it (merged, simplified, one component), not a new triangle
// surface and not postponed there.
void Traversal::refine(Surface&& s, const ShaftGeometry& g, std::vector<Surface>& out, bool settled) {
  size_t left, became;
  { ScopedTimer t(times_[kClassify]); left = classify_edges(s, g); }
  check(s, "classify_edges");
  { ScopedTimer t(times_[kFacings]); became = update_patch_facings(ctx_, s, g); }
  check(s, "update_patch_facings");
  // Early exit (section 4.13). Merging needs a patch whose facing just became
  // consistent (inside edges only ever leave, facings only ever settle), simplifying
  // an edge that just left the shaft (the fresh marks), splitting a connecting edge
  // that just left; with none of them the three passes would reproduce the surface.
  if (settled && left == 0 && became == 0) {
    s.unchanged = true;
    ++n_unchanged_;
    out.push_back(std::move(s));
    return;
  }
  s.unchanged = false;
  { ScopedTimer t(times_[kMerge]); merge_patches(s, ws_); }
  check(s, "merge_patches");
  { ScopedTimer t(times_[kSimplify]); simplify_patches(s, g, ws_); }
  check(s, "simplify_patches");
  size_t before = out.size();
  { ScopedTimer t(times_[kSplit]); split_surface(std::move(s), out, ws_); }
  for (size_t k = before; k < out.size(); ++k) {
    out[k].refined = true;
    check(out[k], "split_surface");
  }
}

void Traversal::finish_surfaces(Shaft& sh, std::vector<Surface>& temp) {
  if (lazy_band()) {
    // The lazy band (Shaft::band): inconsistent triangles leave the surfaces that were
    // refined here (a postponed or unchanged surface had them taken out when it was),
    // and what is left is split into its components again, as SPLIT-SURFACE leaves
    // every surface (the removal rule of section 4.7.8 relies on it, traversal.cpp).
    ScopedTimer t(times_[kBand]);
    prepare_band();
    const size_t kept = sh.band.size();  // in leaf order (filter_band keeps the order)
    std::vector<Surface>& out = band_split_;
    out.clear();
    for (Surface& s : temp) {
      const size_t n = s.unchanged ? 0 : extract_inconsistent(s, sh.band, ws_);
      if (n == 0) {
        out.push_back(std::move(s));
        continue;
      }
      n_band_extracted_ += double(n);
      check(s, "extract_inconsistent");
      if (s.patches.empty()) {
        ws_.recycle(std::move(s));
        continue;
      }
      const size_t before = out.size();
      split_surface(std::move(s), out, ws_);
      for (size_t k = before; k < out.size(); ++k) {
        out[k].refined = true;
        check(out[k], "split_surface (band)");
      }
    }
    temp.swap(out);
    out.clear();
    // The new entries into leaf order, then merged with the kept ones.
    auto by_pos = [&](uint32_t x, uint32_t y) { return tri_pos_[x] < tri_pos_[y]; };
    std::sort(sh.band.begin() + long(kept), sh.band.end(), by_pos);
    std::inplace_merge(sh.band.begin(), sh.band.begin() + long(kept), sh.band.end(), by_pos);
  }
  {
    ScopedTimer t(times_[kLoose]);
    for (Surface& s : temp)
      if (!s.unchanged) compute_loose_edges(ctx_, s);  // unchanged: still current
  }
  {
    ScopedTimer t(times_[kCombine]);
    size_t before = temp.size();
    sh.surfaces.reserve(before);
    combine_surfaces(ctx_, temp, sh.surfaces, sh.g, ws_);
    if (sh.surfaces.size() < before) n_combined_ += double(before - sh.surfaces.size());
  }
  {
    ScopedTimer t(times_[kBounds]);
    for (Surface& s : sh.surfaces)
      if (!s.unchanged) compute_bounds(s, sh.g);
  }
  for (const Surface& s : sh.surfaces) check(s, "combine_surfaces");
}

// CONSTRUCT-SUB-SHAFT (Figure 4.19). The parent's surfaces are copied for the first
// child and moved into the second (section 4.13: no needless copies).
// `made`: this sub-shaft's geometry when choose_split has built it already (the same
// nodes, main axis and scale, so the same bits).
Shaft Traversal::construct_sub_shaft(int r, int l, const TreeNode& split_node, Shaft& parent, bool move_parent,
                          const ShaftGeometry* made) {
  MainAxis ax{parent.g.main_axis(), parent.g.dir()};
  // The geometry is built in place: a default-constructed one assigned afterwards cost
  // two fills and a copy of its plane and corner arrays (1.2 kB) per shaft.
  // Two whole initialisers: each branch's prvalue initialises `sub` itself, so the
  // geometry() branch still builds in place (no temporary and copy).
  Shaft sub = made ? Shaft{r, l, *made, {}, {}, 0, {}} : Shaft{r, l, geometry(r, l, ax), {}, {}, 0, {}};
  init_shaft(sub);
  for (const AABBd& gb : parent.ghosts)
    if (sub.g.may_intersect_box(gb)) sub.ghosts.push_back(gb);
  std::vector<Surface>& temp = temp_;  // not re-entrant: no traversal in between
  temp.clear();
  double work = double(parent.band.size()) + 3.0 * double(split_node.gone.size());
  for (Surface& ps : parent.surfaces) {
    // Early exit (section 4.13): a surface whose box, clamped to the sub-shaft's clip
    // planes, misses the sub-shaft has every edge outside it, cannot block it (the
    // clamped boundary lies in that box, and a plane through the test line separates
    // them) nor any later sub-shaft (their clamped boxes miss them too: the receiver
    // or light box of the sub-shaft lies between), and has no loose edge to combine
    // through, so SHAFT-TRAVERSE would remove it as redundant (section 4.7.8) right
    // after the refinement. It is dropped before the copy; no removed-surface box is
    // needed either, since no segment inside the shaft meets it.
    if (!sub.g.may_intersect_box(clamped_box(ps.box, sub.g))) {
      ++n_dropped_;
      continue;
    }
    // A surface beyond a clip plane (the outer faces of the node boxes on the main
    // axis) meets no segment of the shaft, and one touching it meets only segments'
    // end points there (the boxes are disjoint along the main axis, so every segment
    // leaves that plane at once), which do not block (DESIGN 3). Clamping would instead
    // flatten it onto the plane, where the receiver may be, into a sliver through it.
    // The test is the hull's (Surface::hull): a merged or collapsed patch's boundary
    // may lie beyond while the triangles it stands for cross the sub-shaft; such a
    // surface is kept, never blocks and is never removed (stands_beyond_clip_planes),
    // so its relations go to the rays.
    if (beyond_clip_planes(ps.hull, sub.g)) {
      ++n_dropped_;
      continue;
    }
    if (beyond_clip_planes(ps.box, sub.g)) ++n_kept_beyond_;
    work += double(ps.raw.size());
    Surface s;
    {
      ScopedTimer t(times_[kCopy]);
      if (move_parent) {
        s = std::move(ps);
      } else {
        s = ws_.take_surface();
        s = ps;  // DUPLICATE-SURFACE into pooled arrays: no allocation when they fit
      }
    }
    // Section 4.7.9: postpone the refinement when the vertex centre stays inside and
    // the surface cannot block the shaft yet.
    if (p_.postpone && s.vcount > 0 && sub.g.may_contain_point(s.vsum * (1.0 / s.vcount)) &&
        !can_block_shaft(s.box, sub.g)) {
      s.refined = false;
      s.unchanged = true;  // loose edges and bounds stay as computed for the parent
      ++n_postponed_;
      temp.push_back(std::move(s));
      continue;
    }
    bool settled = s.refined;
    refine(std::move(s), sub.g, temp, settled);
  }
  // The gone triangles (section 4.7.1) and the parent's band triangles that turned
  // consistent for this shaft are built into a new triangle surface together.
  const std::vector<uint32_t>* build = &split_node.gone;
  if (!parent.band.empty()) {
    ScopedTimer t(times_[kBand]);
    filter_band(parent, sub, split_node.gone, band_build_);
    build = &band_build_;
  }
  Surface nt;
  {
    ScopedTimer t(times_[kTriangleSurface]);
    nt = construct_triangle_surface(ctx_, *build, sub.g, rn(r), ln(l), ws_);
  }
  check(nt, "construct_triangle_surface");
  if (!nt.patches.empty()) refine(std::move(nt), sub.g, temp, false);
  else ws_.recycle(std::move(nt));
  finish_surfaces(sub, temp);
  temp.clear();
  light_work_ += work;
  n_shaft_work_ += work;
  account(sub);
  return sub;
}

void Traversal::prepare_band() {
  if (!tri_pos_.empty() || mesh_.triangles.empty()) return;
  const size_t n = mesh_.triangles.size();
  tri_pos_.resize(n);
  const std::span<const uint32_t> order = bvh_->tree().order();
  for (uint32_t pos = 0; pos < order.size(); ++pos) tri_pos_[order[pos]] = pos;
  if (p_.band_build) {  // the facing test of filter_band
    tri_planes_.resize(n);
    tri_plane_ok_.assign(n, 0);
  }
  band_charge_.bind(budget_, "band order and planes");
  band_charge_.set(tri_pos_.capacity() * sizeof(uint32_t) + tri_planes_.capacity() * sizeof(ConservativePlane) +
                   tri_plane_ok_.capacity());
}

const ConservativePlane& Traversal::tri_plane(uint32_t t) {
  if (!tri_plane_ok_[t]) {
    // The shaft's scale is the solve's (Traversal::scale_), so the plane and its
    // tolerance are the same bits update_patch_facings computes.
    tri_planes_[t] = plane_through(to_double(mesh_.corner(t, 0)), to_double(mesh_.corner(t, 1)),
                                   to_double(mesh_.corner(t, 2)), scale_);
    tri_plane_ok_[t] = 1;
  }
  return tri_planes_[t];
}

Facing Traversal::triangle_facing(uint32_t t, const ShaftGeometry& g) { return iss::triangle_facing(tri_plane(t), g); }

// Table 4.1 for a triangle of the parent's band in a sub-shaft that kept the parent's
// light node (light_same) or its receiver node: the same node gives the same box, and a
// band triangle's plane straddles both of the parent's boxes (it was inconsistent
// there), so it still straddles the kept one and only the other box decides, as
// triangle_facing would.
Facing Traversal::band_facing(uint32_t t, const ShaftGeometry& g, bool light_same) {
  const ConservativePlane& pl = tri_plane(t);
  if (pl.n == Vec3d(0, 0, 0)) return Facing::Inconsistent;
  if (light_same) {
    const int rr = classify_box_plane(g.receiver(), pl);
    return rr == 0 ? Facing::TowardsReceiver : rr == 1 ? Facing::TowardsLight : Facing::Inconsistent;
  }
  const int lr = classify_box_plane(g.light(), pl);
  return lr == 0 ? Facing::TowardsLight : lr == 1 ? Facing::TowardsReceiver : Facing::Inconsistent;
}

// The parent's band in sub-shaft `sub`: a triangle whose box misses it is dropped (the
// two tests that drop a surface by its hull in construct_sub_shaft: no segment of the
// sub-shaft or of any shaft below it meets the triangle), one still inconsistent stays
// in sub.band, one that turned consistent goes to `build` after the gone triangles, to
// be built into the sub-shaft's surfaces. A triangle is in at most one place: band
// triangles were valid blockers of the parent, so they are in no inside list of its
// nodes, and gone triangles were in one.
// The box tests go by chunks of kBandChunk consecutive entries (near each other in the
// hierarchy's leaf order): the chunk's box (the union) decides for all of them when it
// is beyond a clip plane or outside a shaft plane, and a triangle is tested only
// against the planes the clamped chunk box straddles. Plane values are monotone in each
// coordinate as evaluated (classify_box_plane), so a plane the chunk box's farthest
// corner passes is passed by every triangle box inside it: the same answers as
// may_intersect_box per triangle.
void Traversal::filter_band(const Shaft& parent, Shaft& sub, const std::vector<uint32_t>& gone,
                            std::vector<uint32_t>& build) {
  build.assign(gone.begin(), gone.end());
  sub.band.reserve(parent.band.size());
  const ShaftGeometry& g = sub.g;
  const int np = g.plane_count();
  std::array<int, 32> straddle{};
  auto corner = [](const AABBd& b, const ConservativePlane& p, bool far) {
    auto pick = [&](double n, double lo, double hi) { return (n > 0) == far ? hi : lo; };
    return Vec3d(pick(p.n.x, b.lo.x, b.hi.x), pick(p.n.y, b.lo.y, b.hi.y), pick(p.n.z, b.lo.z, b.hi.z));
  };
  const std::vector<uint32_t>& band = parent.band;
  const bool light_same = sub.l == parent.l;  // else the receiver node is the same
  for (size_t c0 = 0; c0 < band.size(); c0 += kBandChunk) {
    const size_t c1 = std::min(band.size(), c0 + kBandChunk);
    AABBd cb = to_double(tri_boxes_[band[c0]]);
    for (size_t k = c0 + 1; k < c1; ++k) cb.extend(to_double(tri_boxes_[band[k]]));
    int ns = 0;
    bool out = beyond_clip_planes(cb, g);
    const AABBd ccb = clamped_box(cb, g);
    for (int i = 0; i < np && !out; ++i) {
      const ConservativePlane& p = g.plane(i);
      if (p.eval(corner(ccb, p, false)) > p.tol) out = true;  // may_intersect_box's test
      else if (!(p.eval(corner(ccb, p, true)) <= p.tol)) straddle[size_t(ns++)] = i;
    }
    if (out) {
      n_band_dropped_ += double(c1 - c0);
      continue;
    }
    // A chunk strictly between the clip planes: no box of it is beyond or touching one,
    // and clamping leaves each as it is.
    const int a = g.main_axis();
    const bool in_slab = a >= 0 && cb.lo[a] > g.clip_lo() && cb.hi[a] < g.clip_hi();
    if (in_slab && ns == 0 && !p_.band_build) {  // every box of the chunk passes
      sub.band.insert(sub.band.end(), band.begin() + long(c0), band.begin() + long(c1));
      n_band_kept_ += double(c1 - c0);
      continue;
    }
    for (size_t k = c0; k < c1; ++k) {
      const uint32_t t = band[k];
      const AABBd b = to_double(tri_boxes_[t]);
      bool miss = !in_slab && beyond_clip_planes(b, g);
      const AABBd cbt = in_slab ? b : clamped_box(b, g);
      for (int j = 0; j < ns && !miss; ++j) {
        const ConservativePlane& p = g.plane(straddle[size_t(j)]);
        miss = p.eval(corner(cbt, p, false)) > p.tol;
      }
      if (miss) {
        ++n_band_dropped_;
      } else if (!p_.band_build || band_facing(t, g, light_same) == Facing::Inconsistent) {
        sub.band.push_back(t);
        ++n_band_kept_;
      } else {
        build.push_back(t);
        ++n_band_built_;
      }
    }
  }
}

// The cost rule of shaft_subdivide (automatic rays by cost) for initial shafts, judged
// over the lights: an initial shaft has no smaller shaft of its light to learn from, so
// the initial shafts built so far (with every shaft below them) stand for it. Counts,
// not times, so the choice is the same on every run; the first initial shaft is always
// built, and every kAutoRayExplore-th skipped one still is.
bool Traversal::initial_shaft_by_rays(int r, int l) {
  const AutoRayBucket& ib = initial_bucket_;
  if (!p_.cost_initial || !p_.auto_rays || p_.custom_rays || !cost_rays() || ib.subdivided < 1) return false;
  if (!(ib.work_below > p_.cost_initial_factor * p_.work_per_ray * ib.decided_below)) return false;
  if (++initial_bucket_.skipped % kAutoRayExplore == 0) return false;
  n_cost_ray_initial_ += 1;
  n_cost_ray_shafts_ += 1;
  n_auto_shafts_ += 1;
  n_auto_relations_ += double(rn(r).size()) * double(ln(l).size());
  cast_rays(r, l, nullptr, nullptr);
  return true;
}

// Blocker probe before CONSTRUCT-INITIAL-SHAFT (an addition to section 4.8, in the
// spirit of the early exits of section 4.13). A surface built from any subset of the
// valid blockers of a shaft (triangles that meet the shaft and neither node) that
// passes BLOCKS-SHAFT blocks every box-to-box segment (blockers.h), whatever the other
// triangles are. A blocking surface spans the shaft's cross-section, so the probe
// builds the surfaces of the few triangles whose box is at least as wide as the
// narrower node on both cross axes, and tests them. On rooms this decides the shafts
// from the ground-floor receivers to every upper-floor light with a handful of slab
// triangles instead of the whole mesh. The probe is skipped when the candidates are
// not few (then it would cost about as much as the full construction).
bool Traversal::probe_blocked(int r, int l, MainAxis ax, size_t n_tris) {
  ScopedTimer timer(times_[kProbe]);
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  int a = ax.axis, b = (a + 1) % 3, c = (a + 2) % 3;
  Vec3f re = R.box.extent(), le = L.box.extent();
  float thr = std::min(std::min(re[b], le[b]), std::min(re[c], le[c]));
  probe_order(a);
  const std::vector<float>& ext = wide_extent_[a];
  // Number of triangles with cross extent >= thr (ext is descending; a full prefix
  // means more than any cap).
  size_t n = size_t(std::lower_bound(ext.begin(), ext.end(), thr, [](float x, float v) { return x >= v; }) - ext.begin());
  size_t cap = std::max<size_t>(64, n_tris / 16);
  if (n == 0 || n > cap || (wide_truncated_ && n == ext.size())) return false;
  probe_tris_.assign(wide_[a].begin(), wide_[a].begin() + long(n));
  ShaftGeometry g = geometry(r, l, ax);
  Surface s = construct_triangle_surface(ctx_, probe_tris_, g, R, L, ws_);
  check(s, "construct_triangle_surface (probe)");
  if (s.patches.empty()) {
    ws_.recycle(std::move(s));
    return false;
  }
  probe_out_.clear();
  refine(std::move(s), g, probe_out_, false);
  bool blocked = false;
  for (Surface& ps : probe_out_) {
    compute_bounds(ps, g);
    ++n_blocking_tests_;
    if (!blocked && blocks_shaft(ps, g)) {
      ++n_probe_blocked_;
      blocked = true;
    }
    ws_.recycle(std::move(ps));
  }
  probe_out_.clear();
  return blocked;
}

void Traversal::maybe_build_clusters(size_t n_tris) {
  if (!p_.clusters || clusters_ || n_tris < cluster_threshold()) return;
  ScopedTimer t(times_[kTree]);
  clusters_ = std::make_unique<SurfaceClusters>(mesh_, *bvh_);
  clusters_charge_.bind(budget_, "surface clusters");
  clusters_charge_.set(clusters_->memory_bytes());
}

// CONSTRUCT-INITIAL-SHAFT (Figure 4.31).
Shaft Traversal::construct_initial_shaft(int r, int l, MainAxis ax, const std::vector<uint32_t>& tris) {
  Shaft sh{r, l, geometry(r, l, ax), {}, {}, 0, {}};  // in place, as in construct_sub_shaft
  init_shaft(sh);
  maybe_build_clusters(tris.size());
  Surface s;
  {
    ScopedTimer t(times_[kTriangleSurface]);
    // Once built (Params::clusters), every initial shaft uses the clusters: the walk
    // prunes the hierarchy by the shaft itself, so `tris` is not read.
    // With the lazy band its triangles go to sh.band unbuilt (construct_clustered_surface).
    if (clusters_ && lazy_band()) prepare_band();
    s = clusters_ ? construct_clustered_surface(ctx_, *clusters_, sh.g, rn(r), ln(l), ws_, &n_cluster_patches_,
                                                lazy_band() ? &sh.band : nullptr, p_.cluster_exact_max)
                  : construct_triangle_surface(ctx_, tris, sh.g, rn(r), ln(l), ws_);
  }
  check(s, "construct_triangle_surface");
  n_band_extracted_ += double(sh.band.size());
  light_work_ += double(s.raw.size() + sh.band.size());
  n_shaft_work_ += double(s.raw.size() + sh.band.size());
  std::vector<Surface> temp;
  if (!s.patches.empty()) refine(std::move(s), sh.g, temp, false);
  finish_surfaces(sh, temp);
  account(sh);
  return sh;
}

}  // namespace visgate::iss
