// OpenMesh's readers as an independent reference for lib/io in tests: same
// vertex and face counts and coordinates equal to float precision.
#pragma once

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <string>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"

namespace meshgauge::testing {

using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::Vec2f;
using OpenMesh::Vec3d;
using OpenMesh::Vec3f;
using OpenMesh::Vec3uc;
using OpenMesh::Vec4f;
using OpenMesh::Vec4uc;
using OpenMesh::VertexHandle;

// Receives vertices and faces from OpenMesh's readers; ignores attributes.
class OpenMeshCollector : public OpenMesh::IO::BaseImporter {
 public:
  explicit OpenMeshCollector(Mesh* mesh) : mesh_(mesh) {}

  VertexHandle add_vertex(const Vec3f& p) override {
    return add_vertex(Vec3d(p[0], p[1], p[2]));
  }
  VertexHandle add_vertex(const Vec3d& p) override {
    mesh_->positions.push_back({p[0], p[1], p[2]});
    return VertexHandle(static_cast<int>(mesh_->positions.size() - 1));
  }
  VertexHandle add_vertex() override { return add_vertex(Vec3d(0, 0, 0)); }
  FaceHandle add_face(const VHandles& idx) override {
    Face f;
    f.size = static_cast<int32_t>(idx.size());
    if (f.size <= 4) {
      for (int k = 0; k < f.size; ++k) f.v[k] = idx[k].idx();
    } else {
      ++polygons_;
    }
    mesh_->faces.push_back(f);
    return FaceHandle(static_cast<int>(mesh_->faces.size() - 1));
  }
  void set_point(VertexHandle vh, const Vec3f& p) override {
    if (vh.idx() >= 0 && vh.idx() < static_cast<int>(mesh_->positions.size()))
      mesh_->positions[vh.idx()] = {p[0], p[1], p[2]};
  }
  size_t n_vertices() const override { return mesh_->positions.size(); }
  size_t n_faces() const override { return mesh_->faces.size(); }
  size_t n_edges() const override { return 0; }
  int64_t polygons() const { return polygons_; }

  // Attributes and halfedge-level calls are not needed.
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override {
    return HalfedgeHandle();
  }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle,
                          const std::vector<Vec2f>&) override {}
  void add_face_texcoords(FaceHandle, VertexHandle,
                          const std::vector<Vec3f>&) override {}
  void set_face_texindex(FaceHandle, int) override {}
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const Vec3f&) override {}
  void set_normal(VertexHandle, const Vec3d&) override {}
  void set_color(VertexHandle, const Vec3uc&) override {}
  void set_color(VertexHandle, const Vec4uc&) override {}
  void set_color(VertexHandle, const Vec3f&) override {}
  void set_color(VertexHandle, const Vec4f&) override {}
  void set_texcoord(VertexHandle, const Vec2f&) override {}
  void set_status(VertexHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const Vec2f&) override {}
  void set_texcoord(VertexHandle, const Vec3f&) override {}
  void set_texcoord(HalfedgeHandle, const Vec3f&) override {}
  void set_status(HalfedgeHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const Vec3uc&) override {}
  void set_color(EdgeHandle, const Vec4uc&) override {}
  void set_color(EdgeHandle, const Vec3f&) override {}
  void set_color(EdgeHandle, const Vec4f&) override {}
  void set_status(EdgeHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const Vec3f&) override {}
  void set_normal(FaceHandle, const Vec3d&) override {}
  void set_color(FaceHandle, const Vec3uc&) override {}
  void set_color(FaceHandle, const Vec4uc&) override {}
  void set_color(FaceHandle, const Vec3f&) override {}
  void set_color(FaceHandle, const Vec4f&) override {}
  void set_status(FaceHandle,
                  const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  Mesh* mesh_;
  int64_t polygons_ = 0;
};

// Reads `path` with OpenMesh (binary PLY/STL allowed); polygons are kept as
// faces with size > 4 and no corners. Errors: InvalidArgument when OpenMesh
// cannot read it.
inline absl::StatusOr<Mesh> ReadWithOpenMesh(const std::string& path) {
  Mesh mesh;
  OpenMeshCollector importer(&mesh);
  OpenMesh::IO::Options options;
  options += OpenMesh::IO::Options::Binary;
  if (!OpenMesh::IO::IOManager().read(path, importer, options)) {
    return absl::InvalidArgumentError("OpenMesh cannot read " + path);
  }
  return mesh;
}

}  // namespace meshgauge::testing
