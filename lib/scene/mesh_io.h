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
  std::string format;                 // ".obj", ".off", ".ply" or ".stl" (by extension or content)
  std::vector<std::string> warnings;  // what the reader accepted but a user may want to know
};

// A mesh file's bytes as the readers see them: a UTF-8 byte-order mark dropped, UTF-16
// text (byte-order mark FF FE or FE FF) decoded when it is all ASCII and refused by name
// otherwise, PLY header lines of unknown keywords (`Created by Blender3D`) kept as
// comments with a warning naming the line; and the format, from the extension or, for a
// file without one, from the content. Errors name the file.
struct DecodedMeshFile {
  std::string bytes;
  std::string format;  // ".obj", ".off", ".ply", ".stl"
  std::vector<std::string> warnings;
  bool changed = false;  // bytes differ from the file's
};
Result<DecodedMeshFile> decode_mesh_file(const std::string& path);

// Reads a mesh file (decoded as decode_mesh_file does). Errors name the file and the
// element: unreadable or malformed file, NaN/Inf coordinates ("vertex 12"), face indices
// out of range ("face 7").
Result<PolygonSoup> read_polygon_file(const std::string& path);
// The same on a file decode_mesh_file has already read.
Result<PolygonSoup> read_polygon_file(const std::string& path, const DecodedMeshFile& decoded);

// Fan triangulation (v0, vk, vk+1) of every face, coordinates rounded to float32.
// Faces with fewer than 3 vertices produce no triangle; `short_faces` counts them.
// Fails when a coordinate overflows float32.
Result<TriangleSoup> triangulate(const PolygonSoup& soup, const std::string& origin, size_t* short_faces = nullptr);

}  // namespace visgate
