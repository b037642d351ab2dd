// shrm shader library: the vertex shader of the per-frame pass of shrm_global.glsl, GLSL 3.30
// core. Draw 3 vertices (glDrawArrays(GL_TRIANGLES, 0, 3), any vertex array object bound, no
// attributes): one triangle covering the viewport.
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
