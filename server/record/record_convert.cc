#include "server/record/record_convert.h"

#include <cstdint>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "proto/wire/convert.h"
#include "server/record/session_record.pb.h"

namespace meshgauge::server {
namespace {

static_assert(sizeof(Vec3) == 3 * sizeof(double));

absl::Status Corrupt(const char* what) {
  return absl::DataLossError(
      absl::StrCat("the session store holds a corrupt ", what, " record"));
}

}  // namespace

std::string EncodeInfo(const wire::SessionInfo& info) {
  wire::SessionInfo fixed = info;
  fixed.session_id.clear();
  fixed.generation = fixed.bvh_builds = fixed.bvh_refits = 0;
  fixed.idle_seconds = 0;
  v1::SessionInfo m;
  wire::ToWire(fixed, &m);
  return m.SerializeAsString();
}

absl::StatusOr<wire::SessionInfo> DecodeInfo(const std::string& bytes) {
  v1::SessionInfo m;
  if (!m.ParseFromString(bytes) || (m.dimension() != 2 && m.dimension() != 3) ||
      m.num_vertices() < 1 || m.num_vertices() > INT32_MAX ||
      m.num_faces() < 1 || m.num_faces() > INT32_MAX || m.memory_bytes() < 0) {
    return Corrupt("info");
  }
  return wire::FromWire(m);
}

std::string EncodeTopology(const Mesh& mesh) {
  record::Topology m;
  m.set_dimension(mesh.dimension);
  wire::AppendFaces(mesh.faces, m.mutable_face_sizes(),
                    m.mutable_face_vertices());
  m.mutable_face_regions()->Add(mesh.face_regions.begin(),
                                mesh.face_regions.end());
  for (const auto& [region, dir] : mesh.region_directions) {
    if (dir == ConeDirection::kOutward) {
      m.add_outward_regions(region);
    } else {
      m.add_inward_regions(region);
    }
  }
  return m.SerializeAsString();
}

absl::Status DecodeTopology(const std::string& bytes, int64_t num_vertices,
                            Mesh* mesh) {
  record::Topology m;
  if (!m.ParseFromString(bytes) || (m.dimension() != 2 && m.dimension() != 3) ||
      m.face_sizes().empty() ||
      (!m.face_regions().empty() &&
       m.face_regions_size() != m.face_sizes_size())) {
    return Corrupt("mesh");
  }
  mesh->dimension = m.dimension();
  mesh->faces.resize(m.face_sizes_size());
  int64_t next = 0;
  for (int i = 0; i < m.face_sizes_size(); ++i) {
    Face& f = mesh->faces[i];
    f.size = m.face_sizes(i);
    const bool arity_ok =
        mesh->dimension == 2 ? f.size == 2 : (f.size == 3 || f.size == 4);
    if (!arity_ok || m.face_vertices_size() - next < f.size) {
      return Corrupt("mesh");
    }
    for (int k = 0; k < f.size; ++k) {
      f.v[k] = m.face_vertices(next++);
      if (f.v[k] < 0 || f.v[k] >= num_vertices) return Corrupt("mesh");
    }
  }
  if (next != m.face_vertices_size()) return Corrupt("mesh");
  mesh->face_regions.assign(m.face_regions().begin(), m.face_regions().end());
  mesh->region_directions.clear();
  for (int32_t r : m.inward_regions()) {
    mesh->region_directions[r] = ConeDirection::kInward;
  }
  for (int32_t r : m.outward_regions()) {
    mesh->region_directions[r] = ConeDirection::kOutward;
  }
  return absl::OkStatus();
}

std::string EncodePositions(const std::vector<Vec3>& positions) {
  record::Positions m;
  m.mutable_xyz()->Resize(3 * std::ssize(positions), 0.0);
  std::memcpy(m.mutable_xyz()->mutable_data(), positions.data(),
              positions.size() * sizeof(Vec3));
  return m.SerializeAsString();
}

absl::StatusOr<std::vector<Vec3>> DecodePositions(const std::string& bytes,
                                                  int64_t expected_count) {
  record::Positions m;
  if (!m.ParseFromString(bytes) || m.xyz_size() % 3 != 0 ||
      m.xyz_size() / 3 != expected_count) {
    return Corrupt("positions");
  }
  std::vector<Vec3> out(expected_count);
  std::memcpy(static_cast<void*>(out.data()), m.xyz().data(),
              out.size() * sizeof(Vec3));
  return out;
}

}  // namespace meshgauge::server
