// Triangle meshes for the viewer: a UV sphere, a torus and OBJ files (tinyobjloader), each with
// per-vertex normals, tangents (xyz + handedness w, MikkTSpace-style from the UVs) and UVs, so
// that every render mode (including normal-mapped ones) gets the same attributes.
// World frame of docs/conventions.md (+Y up). Every mesh fits in the unit sphere around the origin.
#ifndef SHRM_VIEWER_MESH_H_
#define SHRM_VIEWER_MESH_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::viewer {

struct Mesh {
  std::vector<float> positions;   // xyz per vertex
  std::vector<float> normals;     // xyz, unit
  std::vector<float> tangents;    // xyzw: unit tangent along +u, w = +-1 (bitangent = w N x T)
  std::vector<float> uvs;         // uv
  std::vector<uint32_t> indices;  // triangles, counter-clockwise seen from outside

  size_t vertex_count() const { return positions.size() / 3; }
  size_t triangle_count() const { return indices.size() / 3; }
};

// Unit sphere at the origin, `segments` around Y and `rings` from pole to pole. Vertex (i, j):
// theta = pi j / rings, phi = 2 pi i / segments, position = the lat-long direction of
// docs/conventions.md (sin t sin p, cos t, -sin t cos p), u = i / segments, v = j / rings; the
// tangent is d/dphi (along the latitude; Kajiya-Kay SHRMs are indexed by it).
Mesh MakeSphere(int segments, int rings);

// Torus around the Y axis, tube centre radius `major`, tube radius `minor` (scaled so that
// major + minor = 1). u along the ring, v around the tube; tangent along u.
Mesh MakeTorus(double major, double minor, int segments, int sides);

// Loads a Wavefront OBJ (all shapes, triangulated). Normals: the file's, or smooth area-weighted
// ones; tangents from the UVs (or any orthonormal vector when the file has none); scaled and
// centred into the unit sphere. Errors (InvalidArgument / NotFound) name the file; Unimplemented
// when built without tinyobjloader.
[[nodiscard]] absl::StatusOr<Mesh> LoadObjMesh(const std::string& path);

// Per-vertex tangents from positions, normals, uvs and indices (accumulated per-triangle dP/du,
// Gram-Schmidt against the normal, handedness from dP/dv); vertices whose UV derivatives are
// degenerate get any unit vector orthogonal to the normal.
void ComputeTangents(Mesh* mesh);

// Centres the mesh's bounding box at the origin and scales it so the farthest vertex is at
// distance `radius`.
void FitInSphere(Mesh* mesh, double radius);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MESH_H_
