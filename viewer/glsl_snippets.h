// GLSL 3.30 pieces shared by the render modes (embedded strings: no shader files at run time).
#ifndef SHRM_VIEWER_GLSL_SNIPPETS_H_
#define SHRM_VIEWER_GLSL_SNIPPETS_H_

namespace shrm::viewer {

// Mesh vertex shader (attributes of viewer/gpu_mesh.h, identity model matrix): outputs the world
// position, normal, tangent (xyzw) and uv. Uniform: mat4 u_view_projection. gl_Position is
// invariant, so passes of different programs over the mesh produce the same depths.
inline constexpr char kMeshVertexShader[] = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
uniform mat4 u_view_projection;
out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
invariant gl_Position;  // equal depths across programs (multi-pass modes)
void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_tangent = a_tangent;
  v_uv = a_uv;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

// The SHRM evaluators (real SH, cube addressing, eqs. 5.35 and 5.10) are the shipped shader
// library, shaders/glsl/ (docs/shaders.md), embedded as shrm::shaders::k*Glsl ("shrm/shaders.h").

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GLSL_SNIPPETS_H_
