// Mesh files (OBJ, OFF, PLY, STL; ASCII and binary) read through OpenMesh's readers into
// a polygon soup that keeps every face. OpenMesh's own mesh importer splits faces it
// cannot add to a half-edge mesh (non-manifold, inconsistently oriented) into isolated
// copies and so loses connectivity; this importer bypasses the half-edge structure and
// stores each face exactly as the file lists it.
#pragma once

#include <string>
#include <vector>

#include "lib/scene/scene.h"

namespace visgate {

struct PolygonSoup {
  std::vector<Vec3d> vertices;  // as read (float files give exact floats)
  std::vector<std::vector<uint32_t>> faces;
  bool double_precision = false;  // some vertex came in as double from the file
  // Attributes the soup does not keep, counted so callers can report them.
  size_t vertex_normals = 0, vertex_colors = 0, texcoords = 0, face_normals = 0, face_colors = 0;
};

// Reads a mesh file. Errors name the file and the element: unreadable or malformed file,
// NaN/Inf coordinates ("vertex 12"), face indices out of range ("face 7").
Result<PolygonSoup> read_polygon_file(const std::string& path);

// Fan triangulation (v0, vk, vk+1) of every face, coordinates rounded to float32.
// Faces with fewer than 3 vertices produce no triangle; `short_faces` counts them.
// Fails when a coordinate overflows float32.
Result<TriangleSoup> triangulate(const PolygonSoup& soup, const std::string& origin, size_t* short_faces = nullptr);

}  // namespace visgate
