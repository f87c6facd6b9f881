#include "server/upload_reception.h"

#include <malloc.h>

#include <iostream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "lib/embree/ray_scene.h"
#include "lib/io/mesh_io.h"
#include "server/session.h"

namespace meshgauge::server {
namespace {

// A refused upload that received more than this returns its memory.
constexpr int64_t kTrimAfterBytes = 1ll << 20;

// An upload the server ended for one of its limits (size, rate, deadline,
// memory): logged with what the client had sent.
bool IsUploadLimit(const absl::Status& s) {
  return s.code() == absl::StatusCode::kDeadlineExceeded ||
         s.code() == absl::StatusCode::kResourceExhausted;
}

}  // namespace

absl::StatusOr<CreatedSession> UploadReception::Receive(
    UploadStream& stream, const std::string& tenant) {
  auto upload = uploads_->Start(stream.context());
  if (!upload.ok()) return upload.status();
  int64_t received = 0;
  auto created = ReceiveUpload(stream, tenant, *upload, &received);
  absl::Status s = created.status();
  if (absl::Status aborted = uploads_->Finish(*upload); !aborted.ok()) {
    s = aborted;
  }
  // A refused upload that received over 1 MiB: give the freed pages back to
  // the system (trimming takes every arena's lock, so not for small ones).
  if (!s.ok() && received > kTrimAfterBytes) malloc_trim(0);
  if (IsUploadLimit(s)) {
    std::cerr << "meshgauge-server: CreateSession ended after " << received
              << " bytes: " << s.message() << std::endl;
  }
  if (!s.ok()) return s;
  return created;
}

void UploadReception::DiscardRest(UploadStream& stream) {
  if (stream.IsCancelled()) return;
  auto discard = uploads_->StartDiscard(stream.context());
  if (!discard.ok()) return;
  UploadMessage message(/*limit=*/0);  // no message is parsed.
  while (stream.Read(&message) &&
         uploads_->Touch(*discard, message.received_bytes).ok()) {
  }
  (void)uploads_->Finish(*discard);
}

absl::StatusOr<CreatedSession> UploadReception::ReceiveUpload(
    UploadStream& stream, const std::string& tenant, int64_t upload,
    int64_t* received) {
  MeshAssembler assembler(options_);
  UploadReservation ticket;
  bool reserved = false;
  UploadMessage message(options_.max_upload_message_bytes);
  while (stream.Read(&message)) {
    *received += message.received_bytes;
    if (!message.refused.empty()) {
      return absl::ResourceExhaustedError(message.refused);
    }
    if (absl::Status s = uploads_->Touch(upload, message.received_bytes);
        !s.ok()) {
      return s;
    }
    if (absl::Status s = assembler.Add(message.request); !s.ok()) return s;
    if (reserved) {
      if (absl::Status s = ticket.Arrived(assembler.bytes_held()); !s.ok()) {
        return s;
      }
    } else {
      // The header's declared size is claimed before any data is buffered.
      auto r = store_->Reserve(tenant, assembler.EstimatedBytes());
      if (!r.ok()) return r.status();
      ticket = std::move(*r);
      reserved = true;
    }
  }
  uploads_->Received(upload);
  if (stream.IsCancelled()) return absl::CancelledError("upload cancelled");
  auto mesh = BuildMesh(stream, assembler, ticket);
  if (!mesh.ok()) return mesh.status();
  // A caller that gave up (deadline, cancel) gets no orphan session.
  if (stream.IsCancelled()) return absl::CancelledError("upload cancelled");
  CreatedSession created;
  created.welded_vertex = std::move(mesh->weld.welded_vertex);
  auto session = store_->Create(tenant, assembler.session_id(),
                                std::move(*mesh), std::move(ticket));
  if (!session.ok()) return session.status();
  created.session = ToSessionInfo((*session)->Snapshot(), clock_->NowSeconds());
  return created;
}

absl::StatusOr<RepairedMesh> UploadReception::BuildMesh(
    UploadStream& stream, MeshAssembler& assembler,
    UploadReservation& ticket) const {
  // Within the server's limits, stopping (between polygons, and every
  // 65,536 faces) when the caller is gone. A file's reader reserves what it
  // holds beyond the header's estimate as it grows (a file's size says
  // little about its mesh); arrays were reserved by their declared counts.
  const int64_t buffered = assembler.bytes_held();
  io::ReadLimits limits{
      .max_vertices = options_.max_vertices,
      .max_faces = options_.max_faces,
      .max_fallback_work = kMaxUploadFallbackWork,
      .cancelled = [&stream] { return stream.IsCancelled(); }};
  if (assembler.file_upload()) {
    limits.reserve = [&](int64_t bytes) {
      return ticket.GrowTo(buffered + bytes);
    };
  }
  auto file = assembler.Finish(limits);
  if (!file.ok()) return file.status();
  // The session's own estimate covers the repairs' transient arrays.
  if (absl::Status s = ticket.GrowTo(Session::EstimateBaseBytes(file->mesh));
      !s.ok()) {
    return s;
  }
  RepairOptions repairs = assembler.repairs();
  repairs.threads = options_.compute_threads;
  auto repaired = RepairFileMesh(std::move(*file), repairs);
  if (!repaired.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("CreateSession: ", repaired.status().message()));
  }
  // A mesh the ray tracer cannot take is refused now, not by every call.
  if (absl::Status s = CheckTraceable(repaired->mesh); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("CreateSession: ", s.message()));
  }
  return repaired;
}

}  // namespace meshgauge::server
