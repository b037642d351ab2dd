#include "viewer/gpu_mesh.h"

namespace shrm::viewer {

GpuMesh::GpuMesh(const Mesh& mesh) {
  vao_ = GlVertexArray::Generate();
  glBindVertexArray(vao_.get());
  const std::vector<float>* data[4] = {&mesh.positions, &mesh.normals, &mesh.tangents, &mesh.uvs};
  const int sizes[4] = {3, 3, 4, 2};
  for (int a = 0; a < 4; ++a) {
    vbo_[a] = GlBuffer::Generate();
    glBindBuffer(GL_ARRAY_BUFFER, vbo_[a].get());
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data[a]->size() * sizeof(float)),
                 data[a]->data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(a);
    glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  ebo_ = GlBuffer::Generate();
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo_.get());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(mesh.indices.size() * sizeof(uint32_t)), mesh.indices.data(),
               GL_STATIC_DRAW);
  index_count_ = static_cast<GLsizei>(mesh.indices.size());
  glBindVertexArray(0);
}

void GpuMesh::Draw() const {
  glBindVertexArray(vao_.get());
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  glBindVertexArray(0);
}

}  // namespace shrm::viewer
