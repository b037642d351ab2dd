#include "viewer/mesh.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "core/base/geometry.h"

#ifdef SHRM_VIEWER_HAVE_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif

namespace shrm::viewer {
namespace {

Vec3 At(const std::vector<float>& v, size_t i) { return {v[3 * i], v[3 * i + 1], v[3 * i + 2]}; }
void Put(std::vector<float>& v, const Vec3& x) {
  v.push_back(static_cast<float>(x.x));
  v.push_back(static_cast<float>(x.y));
  v.push_back(static_cast<float>(x.z));
}

// Any unit vector orthogonal to unit n.
Vec3 Orthogonal(const Vec3& n) {
  const Vec3 a = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return a.Cross(n).Normalized();
}

// Indices of a (segments + 1) x (rows + 1) vertex grid, counter-clockwise seen from the side the
// normals point to when u runs along the columns and v down the rows as in MakeSphere.
void GridIndices(int segments, int rows, bool flip, std::vector<uint32_t>* out) {
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < segments; ++i) {
      const uint32_t a = j * (segments + 1) + i, b = a + 1, c = a + segments + 1, d = c + 1;
      if (flip) {
        out->insert(out->end(), {a, b, c, b, d, c});
      } else {
        out->insert(out->end(), {a, c, b, b, c, d});
      }
    }
}

}  // namespace

Mesh MakeSphere(int segments, int rings) {
  Mesh m;
  for (int j = 0; j <= rings; ++j) {
    const double t = kPi * j / rings;
    for (int i = 0; i <= segments; ++i) {
      const double p = 2 * kPi * i / segments;
      const Vec3 d{std::sin(t) * std::sin(p), std::cos(t), -std::sin(t) * std::cos(p)};
      Put(m.positions, d);
      Put(m.normals, d);
      const Vec3 tan{std::cos(p), 0, std::sin(p)};  // d/dphi / sin(theta), defined at the poles
      const Vec3 dpdv{std::cos(t) * std::sin(p), -std::sin(t), -std::cos(t) * std::cos(p)};
      const double w = d.Cross(tan).Dot(dpdv) >= 0 ? 1.0 : -1.0;
      m.tangents.insert(m.tangents.end(), {static_cast<float>(tan.x), static_cast<float>(tan.y),
                                           static_cast<float>(tan.z), static_cast<float>(w)});
      m.uvs.push_back(static_cast<float>(static_cast<double>(i) / segments));
      m.uvs.push_back(static_cast<float>(static_cast<double>(j) / rings));
    }
  }
  GridIndices(segments, rings, /*flip=*/true, &m.indices);
  return m;
}

Mesh MakeTorus(double major, double minor, int segments, int sides) {
  const double scale = 1 / (major + minor);
  major *= scale;
  minor *= scale;
  Mesh m;
  for (int j = 0; j <= sides; ++j) {
    const double b = 2 * kPi * j / sides;
    for (int i = 0; i <= segments; ++i) {
      const double a = 2 * kPi * i / segments;
      const Vec3 ring{std::cos(a), 0, -std::sin(a)};  // counter-clockwise seen from +Y
      const Vec3 n = ring * std::cos(b) + Vec3{0, 1, 0} * std::sin(b);
      Put(m.positions, ring * major + n * minor);
      Put(m.normals, n);
      const Vec3 tan{-std::sin(a), 0, -std::cos(a)};
      const Vec3 dpdv = (ring * -std::sin(b) + Vec3{0, 1, 0} * std::cos(b));
      const double w = n.Cross(tan).Dot(dpdv) >= 0 ? 1.0 : -1.0;
      m.tangents.insert(m.tangents.end(), {static_cast<float>(tan.x), static_cast<float>(tan.y),
                                           static_cast<float>(tan.z), static_cast<float>(w)});
      m.uvs.push_back(static_cast<float>(static_cast<double>(i) / segments));
      m.uvs.push_back(static_cast<float>(static_cast<double>(j) / sides));
    }
  }
  GridIndices(segments, sides, /*flip=*/true, &m.indices);
  return m;
}

void ComputeTangents(Mesh* mesh) {
  const size_t nv = mesh->vertex_count();
  std::vector<Vec3> tan(nv), bit(nv);
  const bool have_uv = mesh->uvs.size() == 2 * nv;
  if (have_uv) {
    for (size_t f = 0; f + 2 < mesh->indices.size(); f += 3) {
      const uint32_t i0 = mesh->indices[f], i1 = mesh->indices[f + 1], i2 = mesh->indices[f + 2];
      const Vec3 e1 = At(mesh->positions, i1) - At(mesh->positions, i0);
      const Vec3 e2 = At(mesh->positions, i2) - At(mesh->positions, i0);
      const double du1 = mesh->uvs[2 * i1] - mesh->uvs[2 * i0];
      const double dv1 = mesh->uvs[2 * i1 + 1] - mesh->uvs[2 * i0 + 1];
      const double du2 = mesh->uvs[2 * i2] - mesh->uvs[2 * i0];
      const double dv2 = mesh->uvs[2 * i2 + 1] - mesh->uvs[2 * i0 + 1];
      const double det = du1 * dv2 - du2 * dv1;
      if (std::abs(det) < 1e-20) continue;
      const double r = 1 / det;
      const Vec3 t = (e1 * dv2 - e2 * dv1) * r, b = (e2 * du1 - e1 * du2) * r;
      for (uint32_t i : {i0, i1, i2}) {
        tan[i] = tan[i] + t;
        bit[i] = bit[i] + b;
      }
    }
  }
  mesh->tangents.clear();
  for (size_t v = 0; v < nv; ++v) {
    const Vec3 n = At(mesh->normals, v);
    Vec3 t = tan[v] - n * n.Dot(tan[v]);
    double w = 1;
    if (t.Norm() < 1e-12 || !std::isfinite(t.Norm())) {
      t = Orthogonal(n);
    } else {
      t = t.Normalized();
      w = n.Cross(t).Dot(bit[v]) < 0 ? -1 : 1;
    }
    mesh->tangents.insert(mesh->tangents.end(), {static_cast<float>(t.x), static_cast<float>(t.y),
                                                 static_cast<float>(t.z), static_cast<float>(w)});
  }
}

void FitInSphere(Mesh* mesh, double radius) {
  const size_t nv = mesh->vertex_count();
  if (nv == 0) return;
  Vec3 lo = At(mesh->positions, 0), hi = lo;
  for (size_t v = 1; v < nv; ++v) {
    const Vec3 p = At(mesh->positions, v);
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const Vec3 c = (lo + hi) * 0.5;
  double r = 0;
  for (size_t v = 0; v < nv; ++v) r = std::max(r, (At(mesh->positions, v) - c).Norm());
  const double s = r > 0 ? radius / r : 1;
  for (size_t v = 0; v < nv; ++v) {
    const Vec3 p = (At(mesh->positions, v) - c) * s;
    mesh->positions[3 * v] = static_cast<float>(p.x);
    mesh->positions[3 * v + 1] = static_cast<float>(p.y);
    mesh->positions[3 * v + 2] = static_cast<float>(p.z);
  }
}

absl::StatusOr<Mesh> LoadObjMesh(const std::string& path) {
#ifndef SHRM_VIEWER_HAVE_TINYOBJLOADER
  return absl::UnimplementedError(
      absl::StrCat(path, ": OBJ meshes need tinyobjloader (libtinyobjloader-dev) at build time"));
#else
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such file"));
  }
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  config.mtl_search_path = "";
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a valid OBJ file: ", reader.Error()));
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  Mesh m;
  bool have_normals = true, have_uvs = true;
  for (const tinyobj::shape_t& shape : reader.GetShapes())
    for (const tinyobj::index_t& idx : shape.mesh.indices) {
      if (idx.vertex_index < 0 ||
          3 * static_cast<size_t>(idx.vertex_index) + 2 >= attrib.vertices.size())
        return absl::InvalidArgumentError(absl::StrCat(path, ": vertex index out of range"));
      for (int k = 0; k < 3; ++k) m.positions.push_back(attrib.vertices[3 * idx.vertex_index + k]);
      if (idx.normal_index >= 0 &&
          3 * static_cast<size_t>(idx.normal_index) + 2 < attrib.normals.size()) {
        for (int k = 0; k < 3; ++k) m.normals.push_back(attrib.normals[3 * idx.normal_index + k]);
      } else {
        have_normals = false;
        m.normals.insert(m.normals.end(), {0, 0, 0});
      }
      if (idx.texcoord_index >= 0 &&
          2 * static_cast<size_t>(idx.texcoord_index) + 1 < attrib.texcoords.size()) {
        m.uvs.push_back(attrib.texcoords[2 * idx.texcoord_index]);
        m.uvs.push_back(attrib.texcoords[2 * idx.texcoord_index + 1]);
      } else {
        have_uvs = false;
        m.uvs.insert(m.uvs.end(), {0, 0});
      }
      m.indices.push_back(static_cast<uint32_t>(m.indices.size()));
    }
  if (m.indices.empty()) return absl::InvalidArgumentError(absl::StrCat(path, ": no triangles"));
  for (float x : m.positions)
    if (!std::isfinite(x))
      return absl::InvalidArgumentError(absl::StrCat(path, ": non-finite vertex position"));
  FitInSphere(&m, 1.0);
  if (!have_normals) {
    // Smooth normals: area-weighted face normals summed per position (vertices are unshared).
    std::vector<Vec3> acc(m.vertex_count());
    std::vector<std::array<float, 3> > keys(m.vertex_count());
    std::vector<size_t> order(m.vertex_count());
    for (size_t v = 0; v < order.size(); ++v) {
      order[v] = v;
      keys[v] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
    }
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return keys[a] < keys[b]; });
    for (size_t f = 0; f + 2 < m.indices.size(); f += 3) {
      const Vec3 p0 = At(m.positions, f), p1 = At(m.positions, f + 1), p2 = At(m.positions, f + 2);
      const Vec3 n = (p1 - p0).Cross(p2 - p0);
      for (int k = 0; k < 3; ++k) acc[f + k] = n;
    }
    for (size_t b = 0; b < order.size();) {
      size_t e = b;
      Vec3 sum;
      while (e < order.size() && keys[order[e]] == keys[order[b]]) sum = sum + acc[order[e++]];
      for (size_t k = b; k < e; ++k) acc[order[k]] = sum;
      b = e;
    }
    m.normals.clear();
    for (size_t v = 0; v < acc.size(); ++v)
      Put(m.normals, acc[v].Norm() > 0 ? acc[v].Normalized() : Vec3{0, 1, 0});
  } else {
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      Vec3 n = At(m.normals, v);
      n = n.Norm() > 0 ? n.Normalized() : Vec3{0, 1, 0};
      m.normals[3 * v] = static_cast<float>(n.x);
      m.normals[3 * v + 1] = static_cast<float>(n.y);
      m.normals[3 * v + 2] = static_cast<float>(n.z);
    }
  }
  if (!have_uvs) m.uvs.assign(2 * m.vertex_count(), 0.0f);
  ComputeTangents(&m);
  return m;
#endif
}

}  // namespace shrm::viewer
