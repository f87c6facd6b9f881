#include "server/mesh_upload.h"

#include <google/protobuf/io/coded_stream.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "proto/wire/convert.h"

namespace meshgauge::server {
namespace {

absl::Status Invalid(const std::string& what) {
  return absl::InvalidArgumentError(absl::StrCat("CreateSession: ", what));
}

}  // namespace

absl::Status MeshAssembler::Add(const v1::CreateSessionRequest& request) {
  if (have_footer_) return Invalid("data after the footer");
  switch (request.part_case()) {
    case v1::CreateSessionRequest::kHeader:
      return Header(request.header());
    case v1::CreateSessionRequest::kChunk:
      if (!have_header_) return Invalid("the first message must be a header");
      return Chunk(request.chunk());
    case v1::CreateSessionRequest::kFooter:
      if (!have_header_) return Invalid("the first message must be a header");
      return Footer(request.footer());
    default:
      return Invalid("empty message (no header, chunk or footer)");
  }
}

absl::Status MeshAssembler::Header(const v1::CreateSessionRequest::Header& h) {
  if (have_header_) return Invalid("a second header");
  have_header_ = true;
  session_id_ = h.session_id();
  if (h.dimension() != 2 && h.dimension() != 3) {
    return Invalid(
        absl::StrCat("header.dimension must be 2 or 3, got ", h.dimension()));
  }
  if (h.num_vertices() <= 0 || h.num_faces() <= 0) {
    return Invalid(absl::StrCat("header declares ", h.num_vertices(),
                                " vertices and ", h.num_faces(),
                                " faces (need at least one of each)"));
  }
  if (h.num_vertices() > options_.max_vertices) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "CreateSession: ", h.num_vertices(), " vertices exceed the limit of ",
        options_.max_vertices, " per session (--max_vertices)"));
  }
  if (h.num_faces() > options_.max_faces) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "CreateSession: ", h.num_faces(), " faces exceed the limit of ",
        options_.max_faces, " per session (--max_faces)"));
  }
  mesh_.dimension = h.dimension();
  declared_vertices_ = h.num_vertices();
  declared_faces_ = h.num_faces();
  for (const auto& rd : h.region_directions()) {
    if (mesh_.region_directions.count(rd.region())) {
      return Invalid(absl::StrCat("region ", rd.region(),
                                  " is listed twice in region_directions"));
    }
    auto direction = wire::FromWire(rd.direction());
    if (!direction.ok()) {
      return Invalid(absl::StrCat("region ", rd.region(), ": ",
                                  direction.status().message()));
    }
    mesh_.region_directions[rd.region()] = *direction;
  }
  return absl::OkStatus();
}

absl::Status MeshAssembler::CheckRoom(
    const v1::CreateSessionRequest::Chunk& c) const {
  const int dim = mesh_.dimension;
  const int64_t coords =
      declared_vertices_ * dim - mesh_.num_vertices() * dim - std::ssize(coords_);
  if (c.positions_size() > coords) {
    return Invalid(absl::StrCat("a chunk of ", c.positions_size(),
                                " coordinates: more than the declared ",
                                declared_vertices_, " vertices (", coords,
                                " coordinates still to come)"));
  }
  const int64_t sizes =
      declared_faces_ - mesh_.num_faces() - std::ssize(pending_sizes_);
  if (c.face_sizes_size() > sizes) {
    return Invalid(absl::StrCat("a chunk of ", c.face_sizes_size(),
                                " face sizes: more than the declared ",
                                declared_faces_, " faces (", sizes,
                                " still to come)"));
  }
  // At most 4 indices for each face still to come.
  const int64_t indices = 4 * (declared_faces_ - mesh_.num_faces()) -
                          std::ssize(pending_indices_);
  if (c.face_indices_size() > indices) {
    return Invalid(
        absl::StrCat("more face indices than the declared ", declared_faces_,
                     " faces can hold (", mesh_.num_faces(), " complete, ",
                     pending_indices_.size(), " indices pending)"));
  }
  const int64_t regions = declared_faces_ - std::ssize(mesh_.face_regions);
  if (c.face_regions_size() > regions) {
    return Invalid(absl::StrCat("more than the declared ", declared_faces_,
                                " face regions"));
  }
  return absl::OkStatus();
}

int64_t MeshAssembler::bytes_held() const {
  return static_cast<int64_t>(
      mesh_.positions.capacity() * sizeof(Vec3) +
      mesh_.faces.capacity() * sizeof(Face) +
      (mesh_.face_regions.capacity() + pending_sizes_.capacity() +
       pending_indices_.capacity()) *
          sizeof(int32_t) +
      coords_.capacity() * sizeof(double));
}

absl::Status MeshAssembler::Chunk(const v1::CreateSessionRequest::Chunk& c) {
  const int dim = mesh_.dimension;
  // Nothing is stored from a chunk that would exceed the header's counts.
  if (absl::Status s = CheckRoom(c); !s.ok()) return s;
  // Positions.
  if (c.positions_size() > 0) {
    crc_[0] =
        crc32(crc_[0], reinterpret_cast<const Bytef*>(c.positions().data()),
              c.positions_size() * sizeof(double));
    crc_len_[0] += c.positions_size() * sizeof(double);
    for (double x : c.positions()) {
      coords_.push_back(x);
      if (std::ssize(coords_) == dim) {
        mesh_.positions.push_back(
            {coords_[0], coords_[1], dim == 3 ? coords_[2] : 0.0});
        coords_.clear();
      }
    }
  }
  // Faces: sizes and indices may arrive in different chunks.
  if (c.face_sizes_size() > 0) {
    crc_[1] =
        crc32(crc_[1], reinterpret_cast<const Bytef*>(c.face_sizes().data()),
              c.face_sizes_size() * sizeof(int32_t));
    crc_len_[1] += c.face_sizes_size() * sizeof(int32_t);
    for (int32_t s : c.face_sizes()) {
      const bool ok = dim == 2 ? s == 2 : (s == 3 || s == 4);
      if (!ok) {
        return Invalid(absl::StrCat(
            "face ", mesh_.num_faces() + std::ssize(pending_sizes_),
            " has size ", s,
            dim == 2 ? " (2D faces are segments: 2)"
                     : " (3D faces are triangles or quads)"));
      }
      pending_sizes_.push_back(s);
    }
  }
  if (c.face_indices_size() > 0) {
    crc_[2] =
        crc32(crc_[2], reinterpret_cast<const Bytef*>(c.face_indices().data()),
              c.face_indices_size() * sizeof(int32_t));
    crc_len_[2] += c.face_indices_size() * sizeof(int32_t);
    pending_indices_.insert(pending_indices_.end(), c.face_indices().begin(),
                            c.face_indices().end());
  }
  size_t used = 0, consumed_sizes = 0;
  for (int32_t s : pending_sizes_) {
    if (used + s > pending_indices_.size()) break;
    Face f;
    f.size = s;
    for (int k = 0; k < s; ++k) f.v[k] = pending_indices_[used + k];
    mesh_.faces.push_back(f);
    used += s;
    ++consumed_sizes;
  }
  pending_sizes_.erase(pending_sizes_.begin(),
                       pending_sizes_.begin() + consumed_sizes);
  pending_indices_.erase(pending_indices_.begin(),
                         pending_indices_.begin() + used);
  if (!pending_indices_.empty() && pending_sizes_.empty() &&
      mesh_.num_faces() == declared_faces_) {
    return Invalid("more face indices than the face sizes account for");
  }
  if (c.face_regions_size() > 0) {
    crc_[3] =
        crc32(crc_[3], reinterpret_cast<const Bytef*>(c.face_regions().data()),
              c.face_regions_size() * sizeof(int32_t));
    crc_len_[3] += c.face_regions_size() * sizeof(int32_t);
    mesh_.face_regions.insert(mesh_.face_regions.end(),
                              c.face_regions().begin(), c.face_regions().end());
  }
  return absl::OkStatus();
}

absl::Status MeshAssembler::Footer(const v1::CreateSessionRequest::Footer& f) {
  have_footer_ = true;
  if (f.num_vertices() != declared_vertices_ ||
      f.num_faces() != declared_faces_) {
    return Invalid(absl::StrCat("footer counts ", f.num_vertices(),
                                " vertices / ", f.num_faces(),
                                " faces differ from the header's ",
                                declared_vertices_, " / ", declared_faces_));
  }
  footer_crc_ = f.crc32();
  return absl::OkStatus();
}

absl::StatusOr<Mesh> MeshAssembler::Finish() {
  if (!have_header_) return Invalid("empty stream (no header)");
  if (!have_footer_) {
    return Invalid(
        absl::StrCat("truncated stream: no footer after ", mesh_.num_vertices(),
                     " of ", declared_vertices_, " vertices and ",
                     mesh_.num_faces(), " of ", declared_faces_, " faces"));
  }
  if (!coords_.empty() || mesh_.num_vertices() != declared_vertices_) {
    return Invalid(absl::StrCat(
        "received ", mesh_.num_vertices(), " complete vertices (",
        coords_.size(), " stray coordinates), declared ", declared_vertices_));
  }
  if (!pending_sizes_.empty() || !pending_indices_.empty() ||
      mesh_.num_faces() != declared_faces_) {
    return Invalid(absl::StrCat("received ", mesh_.num_faces(),
                                " complete faces, declared ", declared_faces_));
  }
  if (!mesh_.face_regions.empty() &&
      mesh_.num_faces() != std::ssize(mesh_.face_regions)) {
    return Invalid(absl::StrCat("received ", mesh_.face_regions.size(),
                                " face regions for ", mesh_.num_faces(),
                                " faces (send one per face or none)"));
  }
  uLong crc = crc_[0];
  for (int i = 1; i < 4; ++i) crc = crc32_combine(crc, crc_[i], crc_len_[i]);
  if (static_cast<uint32_t>(crc) != footer_crc_) {
    return Invalid(
        absl::StrFormat("checksum mismatch: footer says %08x, data "
                        "has %08x",
                        footer_crc_, static_cast<uint32_t>(crc)));
  }
  if (absl::Status s = ValidateMesh(mesh_); !s.ok()) {
    return Invalid(std::string(s.message()));
  }
  return std::move(mesh_);
}

}  // namespace meshgauge::server

namespace meshgauge::server {
namespace {

// The largest length-delimited top-level field `field` of a serialized
// message (0 when absent), read from its wire bytes without parsing them;
// -1 when they are malformed (the parser then says so).
int64_t LargestField(grpc::ByteBuffer* buffer, uint32_t field) {
  grpc::ProtoBufferReader reader(buffer);
  google::protobuf::io::CodedInputStream in(&reader);
  int64_t largest = 0;
  while (const uint32_t tag = in.ReadTag()) {
    uint64_t u64 = 0;
    uint32_t u32 = 0;
    bool ok = false;
    switch (tag & 7) {
      case 0:
        ok = in.ReadVarint64(&u64);
        break;
      case 1:
        ok = in.ReadLittleEndian64(&u64);
        break;
      case 5:
        ok = in.ReadLittleEndian32(&u32);
        break;
      case 2:
        ok = in.ReadVarint32(&u32) && in.Skip(static_cast<int>(u32));
        if (ok && tag >> 3 == field) {
          largest = std::max<int64_t>(largest, u32);
        }
        break;
      default:
        break;
    }
    if (!ok) return -1;
  }
  return largest;
}

}  // namespace
}  // namespace meshgauge::server

grpc::Status grpc::SerializationTraits<meshgauge::server::UploadMessage,
                                       void>::Deserialize(
    grpc::ByteBuffer* buffer, meshgauge::server::UploadMessage* msg) {
  using meshgauge::server::kMaxUploadHeaderBytes;
  msg->request.Clear();
  msg->refused.clear();
  msg->received_bytes = static_cast<int64_t>(buffer->Length());
  if (msg->received_bytes > msg->limit) {
    msg->refused = absl::StrCat(
        "CreateSession: a message of ", msg->received_bytes,
        " bytes exceeds the upload limit of ", msg->limit,
        " bytes per message (--max_upload_message_bytes); send smaller "
        "chunks");
  } else if (const int64_t header =
                 meshgauge::server::LargestField(buffer, 1);
             header > kMaxUploadHeaderBytes) {
    msg->refused = absl::StrCat(
        "CreateSession: a header of ", header, " bytes exceeds the limit of ",
        kMaxUploadHeaderBytes, " bytes (too many region directions)");
  }
  if (!msg->refused.empty()) {
    buffer->Clear();
    return grpc::Status::OK;
  }
  return grpc::GenericDeserialize<grpc::ProtoBufferReader,
                                  meshgauge::v1::CreateSessionRequest>(
      buffer, &msg->request);
}

grpc::Status grpc::SerializationTraits<meshgauge::server::UploadMessage,
                                       void>::Serialize(
    const meshgauge::server::UploadMessage&, grpc::ByteBuffer*, bool*) {
  return grpc::Status(grpc::StatusCode::UNIMPLEMENTED,
                      "UploadMessage is only read");
}
