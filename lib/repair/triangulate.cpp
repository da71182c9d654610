// Triangulation: polygons by ear clipping, and the triangulate pass of repair_mesh.
#include <string>

#include "lib/repair/passes.h"

namespace visgate::mesh {

bool triangulate_polygon(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& poly, std::vector<Tri>& out) {
  const size_t n = poly.size();
  if (n < 3) return true;
  if (n == 3) {
    out.push_back({poly[0], poly[1], poly[2]});
    return true;
  }
  // Newell normal; project along its dominant axis, keeping the polygon's sense.
  Vec3d nrm(0, 0, 0);
  for (size_t i = 0; i < n; ++i) {
    const Vec3d& a = pos[poly[i]];
    const Vec3d& b = pos[poly[(i + 1) % n]];
    nrm.x += (a.y - b.y) * (a.z + b.z);
    nrm.y += (a.z - b.z) * (a.x + b.x);
    nrm.z += (a.x - b.x) * (a.y + b.y);
  }
  int ax = max_axis(vabs(nrm));
  int u = (ax + 1) % 3, w = (ax + 2) % 3;
  double sense = nrm[ax] >= 0 ? 1.0 : -1.0;
  auto cross2 = [&](uint32_t a, uint32_t b, uint32_t c) {
    const Vec3d &pa = pos[a], &pb = pos[b], &pc = pos[c];
    return sense * ((pb[u] - pa[u]) * (pc[w] - pa[w]) - (pb[w] - pa[w]) * (pc[u] - pa[u]));
  };
  std::vector<uint32_t> ring(poly);
  bool ears_only = true;
  while (ring.size() > 3) {
    const size_t m = ring.size();
    size_t best = m;
    for (size_t i = 0; i < m && best == m; ++i) {
      uint32_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (!(cross2(a, b, c) > 0)) continue;  // reflex or flat corner: not an ear
      bool empty = true;
      for (size_t j = 0; j < m && empty; ++j) {
        uint32_t p = ring[j];
        if (p == a || p == b || p == c) continue;
        if (cross2(a, b, p) >= 0 && cross2(b, c, p) >= 0 && cross2(c, a, p) >= 0) empty = false;
      }
      if (empty) best = i;
    }
    if (best == m) {  // no ear (self-intersecting or degenerate polygon): fan the rest
      ears_only = false;
      for (size_t k = 1; k + 1 < ring.size(); ++k) out.push_back({ring[0], ring[k], ring[k + 1]});
      return false;
    }
    out.push_back({ring[(best + m - 1) % m], ring[best], ring[(best + 1) % m]});
    ring.erase(ring.begin() + long(best));
  }
  out.push_back({ring[0], ring[1], ring[2]});
  return ears_only;
}

namespace {

// The shortest period p >= 3 with face[i] == face[i mod p] for every i (a polygon that
// lists its vertex cycle several times over), else face.size().
size_t repeated_cycle_period(const std::vector<uint32_t>& face) {
  const size_t n = face.size();
  for (size_t p = 3; p * 2 <= n; ++p) {
    if (n % p != 0) continue;
    bool repeats = true;
    for (size_t i = p; i < n && repeats; ++i) repeats = face[i] == face[i - p];
    if (repeats) return p;
  }
  return n;
}

}  // namespace

Result<TriangulateCounts> triangulate_faces(const PolygonSoup& soup, Work& w, std::vector<RemovedTriangle>& removed) {
  TriangulateCounts c;
  std::vector<Tri> buf;
  for (uint32_t f = 0; f < soup.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    for (uint32_t v : face)
      if (v >= w.pos.size())
        return Error{"face " + std::to_string(f) + ": vertex index " + std::to_string(v) + " out of range"};
    if (face.size() < 3) {
      removed.push_back({f, "short_face"});
      ++c.short_faces_dropped;
      continue;
    }
    buf.clear();
    const size_t period = repeated_cycle_period(face);
    if (period < face.size()) ++c.repeated_cycles_collapsed;
    if (period > 3) {
      ++c.polygons_triangulated;
      const std::vector<uint32_t> cycle(face.begin(), face.begin() + long(period));
      if (!triangulate_polygon(w.pos, cycle, buf)) ++c.fan_fallbacks;
      c.triangles_from_polygons += buf.size();
    } else {
      buf.push_back({face[0], face[1], face[2]});
    }
    for (const Tri& t : buf) {
      w.tris.push_back(t);
      w.src.push_back(f);
    }
  }
  if (w.tris.empty())
    return Error{"no faces (" + std::to_string(soup.vertices.size()) + " vertices, " + std::to_string(soup.faces.size()) +
                 " faces, none with three or more vertices): not a surface mesh"};
  return c;
}

StepRecord TriangulateCounts::record(double seconds) const {
  return {"triangulate",
          {{"polygons_triangulated", polygons_triangulated},
           {"triangles_from_polygons", triangles_from_polygons},
           {"fan_fallbacks", fan_fallbacks},
           {"repeated_cycles_collapsed", repeated_cycles_collapsed},
           {"short_faces_dropped", short_faces_dropped}},
          seconds};
}

}  // namespace visgate::mesh
