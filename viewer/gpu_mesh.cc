#include "viewer/gpu_mesh.h"

namespace shrm::viewer {

GpuMesh::GpuMesh(const Mesh& mesh) {
  glGenVertexArrays(1, &vao_);
  glBindVertexArray(vao_);
  glGenBuffers(4, vbo_);
  const std::vector<float>* data[4] = {&mesh.positions, &mesh.normals, &mesh.tangents, &mesh.uvs};
  const int sizes[4] = {3, 3, 4, 2};
  for (int a = 0; a < 4; ++a) {
    glBindBuffer(GL_ARRAY_BUFFER, vbo_[a]);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data[a]->size() * sizeof(float)),
                 data[a]->data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(a);
    glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  glGenBuffers(1, &ebo_);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(uint32_t)), mesh.indices.data(),
               GL_STATIC_DRAW);
  index_count_ = static_cast<GLsizei>(mesh.indices.size());
  glBindVertexArray(0);
}

GpuMesh::~GpuMesh() {
  glDeleteBuffers(4, vbo_);
  glDeleteBuffers(1, &ebo_);
  glDeleteVertexArrays(1, &vao_);
}

void GpuMesh::Draw() const {
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

}  // namespace shrm::viewer
