#include "proto/wire/upload_convert.h"

#include <zlib.h>

#include <algorithm>

#include "proto/wire/convert.h"

namespace meshgauge::wire {
namespace {

template <typename T>
void Extend(const google::protobuf::RepeatedField<T>& field, uLong* crc,
            int64_t* bytes) {
  if (field.empty()) return;
  *crc = crc32(*crc, reinterpret_cast<const Bytef*>(field.data()),
               field.size() * sizeof(T));
  *bytes += field.size() * sizeof(T);
}

}  // namespace

void UploadCrc::Add(const v1::CreateSessionRequest::Chunk& c) {
  Extend(c.positions(), &crc_[0], &bytes_[0]);
  Extend(c.face_sizes(), &crc_[1], &bytes_[1]);
  Extend(c.face_indices(), &crc_[2], &bytes_[2]);
  Extend(c.face_regions(), &crc_[3], &bytes_[3]);
}

void UploadCrc::AddFile(std::string_view bytes) {
  crc_[0] = crc32(crc_[0], reinterpret_cast<const Bytef*>(bytes.data()),
                  bytes.size());
  bytes_[0] += std::ssize(bytes);
}

uint32_t UploadCrc::Value() const {
  uLong combined = crc_[0];
  for (int i = 1; i < 4; ++i) {
    combined = crc32_combine(combined, crc_[i], bytes_[i]);
  }
  return static_cast<uint32_t>(combined);
}

bool WriteUpload(
    const Mesh& mesh, const std::string& session_id, int64_t per_chunk,
    const std::function<bool(const v1::CreateSessionRequest&)>& write) {
  v1::CreateSessionRequest req;
  auto* h = req.mutable_header();
  h->set_session_id(session_id);
  h->set_dimension(mesh.dimension);
  h->set_num_vertices(mesh.num_vertices());
  h->set_num_faces(mesh.num_faces());
  for (const auto& [region, dir] : mesh.region_directions) {
    auto* rd = h->add_region_directions();
    rd->set_region(region);
    rd->set_direction(ToWire(dir));
  }
  if (!write(req)) return false;
  UploadCrc crc;
  const int64_t step = std::max<int64_t>(1, per_chunk);
  const int64_t n = std::max(mesh.num_vertices(), mesh.num_faces());
  for (int64_t begin = 0; begin < n; begin += step) {
    req.Clear();
    auto* c = req.mutable_chunk();
    if (begin < mesh.num_vertices()) {
      AppendFlattened(absl::MakeConstSpan(mesh.positions)
                          .subspan(begin, static_cast<size_t>(step)),
                      mesh.dimension, c->mutable_positions());
    }
    if (begin < mesh.num_faces()) {
      const size_t end =
          static_cast<size_t>(std::min(begin + step, mesh.num_faces()));
      AppendFaces(absl::MakeConstSpan(mesh.faces).subspan(begin, end - begin),
                  c->mutable_face_sizes(), c->mutable_face_indices());
      if (!mesh.face_regions.empty()) {
        c->mutable_face_regions()->Add(mesh.face_regions.begin() + begin,
                                       mesh.face_regions.begin() + end);
      }
    }
    crc.Add(*c);
    if (!write(req)) return false;
  }
  req.Clear();
  auto* footer = req.mutable_footer();
  footer->set_num_vertices(mesh.num_vertices());
  footer->set_num_faces(mesh.num_faces());
  footer->set_crc32(crc.Value());
  return write(req);
}

}  // namespace meshgauge::wire
