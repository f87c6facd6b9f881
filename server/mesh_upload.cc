#include "server/mesh_upload.h"

#include <google/protobuf/io/coded_stream.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lib/core/polygon.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/mesh_io.h"
#include "proto/wire/convert.h"
#include "server/session.h"

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
      return file_format_.empty() ? Chunk(request.chunk())
                                  : FileChunk(request.chunk());
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
  if (h.weld() && !(h.weld_tolerance() == 0 ||
                    (h.weld_tolerance() >= kMinWeldTolerance &&
                     h.weld_tolerance() <= kMaxWeldTolerance))) {
    return Invalid(absl::StrCat(
        "header.weld_tolerance must be 0 (exact duplicates) or in [",
        kMinWeldTolerance, ", ", kMaxWeldTolerance, "], got ",
        h.weld_tolerance()));
  }
  repairs_ = {.weld = h.weld(),
              .weld_tolerance = h.weld_tolerance(),
              .drop_degenerate_faces = h.drop_degenerate_faces(),
              .reorient = h.reorient()};
  for (const auto& rd : h.region_directions()) {
    if (region_directions_.count(rd.region())) {
      return Invalid(absl::StrCat("region ", rd.region(),
                                  " is listed twice in region_directions"));
    }
    auto direction = wire::FromWire(rd.direction());
    if (!direction.ok()) {
      return Invalid(absl::StrCat("region ", rd.region(), ": ",
                                  direction.status().message()));
    }
    region_directions_[rd.region()] = *direction;
  }
  if (!h.file_format().empty() || h.file_bytes() != 0) return FileHeader(h);
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
  const int64_t min_corners = h.dimension() == 2 ? 2 : 3;
  const int64_t max_corners = h.dimension() == 2 ? 2 : kMaxPolygonCorners;
  if (h.num_face_indices() != 0 &&
      (h.num_face_indices() < min_corners * h.num_faces() ||
       h.num_face_indices() > max_corners * h.num_faces())) {
    return Invalid(absl::StrCat("header.num_face_indices is ",
                                h.num_face_indices(), " for ", h.num_faces(),
                                " faces (each face has ", min_corners, " to ",
                                max_corners, " corners; 0: at most 4)"));
  }
  // Polygons become n - 2 triangles each, triangles and quads stay: the
  // fewest faces these indices make.
  if (const int64_t faces =
          h.num_faces() +
          std::max<int64_t>(0, h.num_face_indices() - 4 * h.num_faces());
      faces > options_.max_faces) {
    return absl::ResourceExhaustedError(
        absl::StrCat("CreateSession: the polygons make at least ", faces,
                     " faces once triangulated, over the limit of ",
                     options_.max_faces, " faces per session (--max_faces)"));
  }
  dimension_ = h.dimension();
  declared_vertices_ = h.num_vertices();
  declared_faces_ = h.num_faces();
  declared_indices_ = h.num_face_indices();
  return absl::OkStatus();
}

absl::Status MeshAssembler::FileHeader(
    const v1::CreateSessionRequest::Header& h) {
  // A format the readers take, named in lower case.
  if (!IsMeshExtension(absl::StrCat(".", h.file_format())) ||
      h.file_format() != absl::AsciiStrToLower(h.file_format())) {
    return Invalid(
        absl::StrCat("header.file_format must be obj, off, ply or "
                     "stl, got '",
                     absl::CEscape(h.file_format().substr(0, 16)), "'"));
  }
  if (h.dimension() != 0 || h.num_vertices() != 0 || h.num_faces() != 0 ||
      h.num_face_indices() != 0) {
    return Invalid(
        "a file upload's header has dimension, num_vertices, num_faces and "
        "num_face_indices 0 (the file holds them)");
  }
  if (h.file_bytes() <= 0) {
    return Invalid(absl::StrCat("header.file_bytes must be positive, got ",
                                h.file_bytes()));
  }
  if (const int64_t limit = MaxUploadFileBytes(options_);
      h.file_bytes() > limit) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "CreateSession: a file of ", h.file_bytes(),
        " bytes exceeds the limit of ", limit,
        " bytes (--max_upload_file_bytes, and 1/8 of the memory budget)"));
  }
  if (h.file_name().size() > 256) {
    return Invalid("header.file_name is longer than 256 bytes");
  }
  file_format_ = absl::StrCat(".", h.file_format());
  declared_file_bytes_ = h.file_bytes();
  file_name_ = h.file_name().empty()
                   ? absl::StrCat("uploaded file", file_format_)
                   : absl::CHexEscape(h.file_name());
  return absl::OkStatus();
}

int64_t MeshAssembler::EstimatedBytes() const {
  if (!file_format_.empty()) {
    // The file's bytes and a start for what a reader holds while it reads
    // them; the reader reserves more as it needs it (ReadLimits::reserve).
    return declared_file_bytes_ * kFileReadFactor;
  }
  const int64_t primitives =
      declared_indices_ == 0
          ? declared_faces_
          : std::max(declared_faces_, declared_indices_ - 2 * declared_faces_);
  return Session::EstimateBytes(declared_vertices_, declared_faces_,
                                primitives);
}

absl::Status MeshAssembler::CheckRoom(
    const v1::CreateSessionRequest::Chunk& c) const {
  if (!c.file_data().empty()) {
    return Invalid("file_data in an upload of arrays (no header.file_format)");
  }
  const int64_t coords = declared_vertices_ * dimension_ - std::ssize(coords_);
  if (c.positions_size() > coords) {
    return Invalid(absl::StrCat("a chunk of ", c.positions_size(),
                                " coordinates: more than the declared ",
                                declared_vertices_, " vertices (", coords,
                                " coordinates still to come)"));
  }
  const int64_t sizes = declared_faces_ - std::ssize(sizes_);
  if (c.face_sizes_size() > sizes) {
    return Invalid(absl::StrCat("a chunk of ", c.face_sizes_size(),
                                " face sizes: more than the declared ",
                                declared_faces_, " faces (", sizes,
                                " still to come)"));
  }
  const int64_t indices =
      (declared_indices_ != 0 ? declared_indices_ : 4 * declared_faces_) -
      std::ssize(indices_);
  if (c.face_indices_size() > indices) {
    return Invalid(absl::StrCat(
        "a chunk of ", c.face_indices_size(),
        " face indices: more face indices than the declared ",
        declared_indices_ != 0
            ? absl::StrCat(declared_indices_, " (num_face_indices)")
            : absl::StrCat(declared_faces_, " faces can hold (4 each)"),
        "; ", indices, " still to come"));
  }
  const int64_t regions = declared_faces_ - std::ssize(regions_);
  if (c.face_regions_size() > regions) {
    return Invalid(absl::StrCat("more than the declared ", declared_faces_,
                                " face regions"));
  }
  return absl::OkStatus();
}

int64_t MeshAssembler::bytes_held() const {
  // The buffers, and the mesh Finish makes of them while they are held.
  const int64_t vertices =
      dimension_ > 0 ? std::ssize(coords_) / dimension_ : 0;
  return static_cast<int64_t>(
      coords_.capacity() * sizeof(double) + vertices * sizeof(Vec3) +
      (sizes_.capacity() + indices_.capacity() + regions_.capacity()) *
          sizeof(int32_t) +
      sizes_.size() * sizeof(Face) + file_.size());
}

namespace {

template <typename T>
void Append(const google::protobuf::RepeatedField<T>& from,
            std::vector<T>* to) {
  to->insert(to->end(), from.begin(), from.end());
}

}  // namespace

absl::Status MeshAssembler::Chunk(const v1::CreateSessionRequest::Chunk& c) {
  const int max_size =
      dimension_ == 2 ? 2 : (declared_indices_ != 0 ? kMaxPolygonCorners : 4);
  const int min_size = dimension_ == 2 ? 2 : 3;
  for (int i = 0; i < c.face_sizes_size(); ++i) {
    const int32_t s = c.face_sizes(i);
    if (s < min_size || s > max_size) {
      return Invalid(
          absl::StrCat("face ", std::ssize(sizes_) + i, " has size ", s,
                       dimension_ == 2 ? " (2D faces are segments: 2)"
                       : declared_indices_ != 0
                           ? absl::StrCat(" (3D faces have 3 to ",
                                          kMaxPolygonCorners, " corners)")
                           : " (3D faces are triangles or quads; declare "
                             "header.num_face_indices to send polygons)"));
    }
  }
  // Nothing is stored from a chunk that would exceed the header's counts.
  if (absl::Status s = CheckRoom(c); !s.ok()) return s;
  crc_.Add(c);
  Append(c.positions(), &coords_);
  Append(c.face_sizes(), &sizes_);
  Append(c.face_indices(), &indices_);
  Append(c.face_regions(), &regions_);
  return absl::OkStatus();
}

absl::Status MeshAssembler::FileChunk(
    const v1::CreateSessionRequest::Chunk& c) {
  if (c.positions_size() > 0 || c.face_sizes_size() > 0 ||
      c.face_indices_size() > 0 || c.face_regions_size() > 0) {
    return Invalid("a file upload's chunks carry file_data only");
  }
  const int64_t room = declared_file_bytes_ - std::ssize(file_);
  if (std::ssize(c.file_data()) > room) {
    return Invalid(absl::StrCat("a chunk of ", c.file_data().size(),
                                " file bytes: more than the declared ",
                                declared_file_bytes_, " (", room,
                                " still to come)"));
  }
  if (file_.empty()) file_.reserve(declared_file_bytes_);
  crc_.AddFile(c.file_data());
  file_ += c.file_data();
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

absl::Status MeshAssembler::CheckCrc() const {
  const uint32_t crc = crc_.Value();
  if (crc == footer_crc_) return absl::OkStatus();
  return Invalid(absl::StrFormat(
      "checksum mismatch: footer says %08x, the data sent has %08x",
      footer_crc_, crc));
}

absl::StatusOr<io::MeshFile> MeshAssembler::Finish(
    const io::ReadLimits& limits) {
  if (!have_header_) return Invalid("empty stream (no header)");
  if (!have_footer_) {
    return Invalid(absl::StrCat(
        "truncated stream: no footer after ",
        file_format_.empty()
            ? absl::StrCat(std::ssize(coords_) / dimension_, " of ",
                           declared_vertices_, " vertices and ", sizes_.size(),
                           " of ", declared_faces_, " faces")
            : absl::StrCat(file_.size(), " of ", declared_file_bytes_,
                           " file bytes")));
  }
  auto file = file_format_.empty() ? FinishArrays(limits) : FinishFile(limits);
  if (!file.ok()) return file.status();
  for (const auto& [region, direction] : region_directions_) {
    file->mesh.region_directions[region] = direction;
  }
  return file;
}

absl::StatusOr<io::MeshFile> MeshAssembler::FinishArrays(
    const io::ReadLimits& limits) {
  const int64_t vertices = std::ssize(coords_) / dimension_;
  if (std::ssize(coords_) != declared_vertices_ * dimension_) {
    return Invalid(absl::StrCat("received ", vertices, " complete vertices (",
                                std::ssize(coords_) % dimension_,
                                " stray coordinates), declared ",
                                declared_vertices_));
  }
  int64_t used = 0;
  for (int32_t s : sizes_) used += s;
  if (std::ssize(sizes_) != declared_faces_ || used != std::ssize(indices_)) {
    return Invalid(absl::StrCat("received ", sizes_.size(),
                                " face sizes (declared ", declared_faces_,
                                ") and ", indices_.size(),
                                " face indices (the sizes need ", used, ")"));
  }
  if (declared_indices_ != 0 && used != declared_indices_) {
    return Invalid(absl::StrCat("received ", used,
                                " face indices, header.num_face_indices "
                                "declared ",
                                declared_indices_));
  }
  if (!regions_.empty() && std::ssize(regions_) != declared_faces_) {
    return Invalid(absl::StrCat("received ", regions_.size(),
                                " face regions for ", declared_faces_,
                                " faces (send one per face or none)"));
  }
  if (absl::Status s = CheckCrc(); !s.ok()) return s;
  io::MeshBuilder builder("CreateSession", dimension_, &limits);
  if (absl::Status s = builder.ReservePositions(vertices); !s.ok()) return s;
  for (int64_t v = 0; v < vertices; ++v) {
    const double* x = coords_.data() + v * dimension_;
    if (absl::Status s =
            builder.AddVertex({x[0], x[1], dimension_ == 3 ? x[2] : 0.0});
        !s.ok()) {
      return s;
    }
  }
  std::vector<double>().swap(coords_);
  std::vector<int64_t> corners;
  int64_t offset = 0;
  for (int64_t f = 0; f < std::ssize(sizes_); ++f) {
    corners.assign(indices_.begin() + offset,
                   indices_.begin() + offset + sizes_[f]);
    offset += sizes_[f];
    if (absl::Status s =
            builder.AddFace(corners, regions_.empty() ? 0 : regions_[f],
                            [] { return std::string("face_indices"); });
        !s.ok()) {
      return s;
    }
  }
  std::vector<int32_t>().swap(indices_);
  std::vector<int32_t>().swap(sizes_);
  auto file = builder.Finish("arrays");
  if (!file.ok()) return file.status();
  if (!regions_.empty() && file->mesh.face_regions.empty()) {
    file->mesh.face_regions.assign(file->mesh.faces.size(), 0);
  }
  std::vector<int32_t>().swap(regions_);
  return file;
}

absl::StatusOr<io::MeshFile> MeshAssembler::FinishFile(
    const io::ReadLimits& limits) {
  if (std::ssize(file_) != declared_file_bytes_) {
    return Invalid(absl::StrCat("received ", file_.size(),
                                " file bytes, declared ",
                                declared_file_bytes_));
  }
  if (absl::Status s = CheckCrc(); !s.ok()) return s;
  auto file = ParseMeshContents(file_, file_format_, file_name_, limits);
  std::string().swap(file_);
  return file;
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

bool ParseUploadMessage(grpc::ByteBuffer* buffer, UploadMessage* msg) {
  msg->request.Clear();
  msg->refused.clear();
  msg->received_bytes = static_cast<int64_t>(buffer->Length());
  if (msg->received_bytes > msg->limit) {
    msg->refused = absl::StrCat(
        "CreateSession: a message of ", msg->received_bytes,
        " bytes exceeds the upload limit of ", msg->limit,
        " bytes per message (--max_upload_message_bytes); send smaller "
        "chunks");
  } else if (const int64_t header = LargestField(buffer, 1);
             header > kMaxUploadHeaderBytes) {
    msg->refused = absl::StrCat(
        "CreateSession: a header of ", header, " bytes exceeds the limit of ",
        kMaxUploadHeaderBytes, " bytes (too many region directions)");
  }
  if (!msg->refused.empty()) {
    buffer->Clear();
    return true;
  }
  return grpc::GenericDeserialize<grpc::ProtoBufferReader,
                                  v1::CreateSessionRequest>(buffer,
                                                            &msg->request)
      .ok();
}

}  // namespace meshgauge::server
