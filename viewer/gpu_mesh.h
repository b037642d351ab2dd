// A Mesh (viewer/mesh.h) in GL buffers. Vertex attributes, the same for every render mode:
//   location 0: vec3 position (world; meshes are drawn with an identity model matrix)
//   location 1: vec3 normal   (unit)
//   location 2: vec4 tangent  (xyz unit, w = handedness: bitangent = w cross(N, T))
//   location 3: vec2 uv
#ifndef SHRM_VIEWER_GPU_MESH_H_
#define SHRM_VIEWER_GPU_MESH_H_

#include <epoxy/gl.h>

#include <memory>

#include "viewer/mesh.h"

namespace shrm::viewer {

class GpuMesh {
 public:
  explicit GpuMesh(const Mesh& mesh);
  ~GpuMesh();
  GpuMesh(const GpuMesh&) = delete;
  GpuMesh& operator=(const GpuMesh&) = delete;

  // Binds the VAO and draws all triangles (the caller's program must be in use).
  void Draw() const;
  size_t triangle_count() const { return index_count_ / 3; }

 private:
  GLuint vao_ = 0, ebo_ = 0;
  GLuint vbo_[4] = {0, 0, 0, 0};
  GLsizei index_count_ = 0;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GPU_MESH_H_
