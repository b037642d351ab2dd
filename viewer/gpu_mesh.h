// A Mesh (viewer/mesh.h) in GL buffers. Vertex attributes, the same for every render mode:
//   location 0: vec3 position (world; meshes are drawn with an identity model matrix)
//   location 1: vec3 normal   (unit)
//   location 2: vec4 tangent  (xyz unit, w = handedness: bitangent = w cross(N, T))
//   location 3: vec2 uv
#ifndef SHRM_VIEWER_GPU_MESH_H_
#define SHRM_VIEWER_GPU_MESH_H_

#include <epoxy/gl.h>

#include <array>
#include <memory>

#include "viewer/gl_util.h"
#include "viewer/mesh.h"

namespace shrm::viewer {

class GpuMesh {
 public:
  // GL context must be current (also when it is destroyed: gl_util.h).
  explicit GpuMesh(const Mesh& mesh);

  // Binds the VAO and draws all triangles (the caller's program must be in use).
  void Draw() const;
  size_t triangle_count() const { return index_count_ / 3; }

 private:
  // Destroyed in reverse order: the vertex buffers, the index buffer, the vertex array.
  GlVertexArray vao_;
  GlBuffer ebo_;
  std::array<GlBuffer, 4> vbo_;
  GLsizei index_count_ = 0;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GPU_MESH_H_
