// The reception of a CreateSession upload, apart from its transport: the
// stream's messages are read (each checked before it is parsed), timed by
// UploadWatch, assembled (MeshAssembler) within the memory reserved for
// them in the store, built into a repaired mesh and made a session.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "proto/wire/types.h"
#include "server/clock.h"
#include "server/mesh_upload.h"
#include "server/server_options.h"
#include "server/session_store.h"
#include "server/upload_watch.h"

namespace meshgauge::server {

// The messages of one CreateSession call.
class UploadStream {
 public:
  virtual ~UploadStream() = default;
  // The next message (read with ParseUploadMessage); false, now and from
  // then on, at the end of the stream or when it broke or was cancelled.
  virtual bool Read(UploadMessage* message) = 0;
  // Read returned false.
  virtual bool ended() const = 0;
  virtual bool IsCancelled() const = 0;
  // The call, for UploadWatch to cancel.
  virtual grpc::ServerContextBase* context() = 0;
};

// What a received upload made.
struct CreatedSession {
  wire::SessionInfo session;
  std::vector<int32_t> welded_vertex;  // per uploaded vertex: the kept one.
};

class UploadReception {
 public:
  // All pointers must outlive the object.
  UploadReception(const ServerOptions& options, SessionStore* store,
                  UploadWatch* uploads, const Clock* clock)
      : options_(options), store_(store), uploads_(uploads), clock_(clock) {}

  // Receives `stream` as an upload of `tenant` and creates its session.
  // Errors: RESOURCE_EXHAUSTED (too many uploads, a message or header over
  // its limit, the reservation), DEADLINE_EXCEEDED (UploadWatch's limits,
  // an upload cancelled as idle), INVALID_ARGUMENT (the upload's content,
  // a mesh the repairs or the ray tracer refuse), CANCELLED when the caller
  // left, and SessionStore::Create's.
  absl::StatusOr<CreatedSession> Receive(UploadStream& stream,
                                         const std::string& tenant);

  // Reads and drops the rest of an upload refused before its client
  // finished sending (precondition: !stream.ended()), so that the refusal
  // ends a complete request: an HTTP/2 proxy such as HAProxy 2.6 (haproxy
  // issue 1219) loses a reply that closes a stream the client still sends
  // on, together with the RST_STREAM(NO_ERROR) that follows it, and gives
  // the client CANCELLED instead of the status. Bounded by UploadWatch (at
  // most kMaxDiscards at once, kMaxDiscardBytes, kMaxDiscardSeconds; the
  // sweeper cancels a discard past its time, silent or not, within a
  // second): past the bytes the refusal is sent at once, past the time the
  // call is cancelled.
  void DiscardRest(UploadStream& stream);

 private:
  // The upload `upload` (of UploadWatch) after its slot was taken;
  // `received` counts the bytes of its messages.
  absl::StatusOr<CreatedSession> ReceiveUpload(UploadStream& stream,
                                               const std::string& tenant,
                                               int64_t upload,
                                               int64_t* received);
  // The mesh of a received upload (its footer arrived): read or built
  // within the server's limits and `ticket`, repaired and diagnosed.
  absl::StatusOr<RepairedMesh> BuildMesh(UploadStream& stream,
                                         MeshAssembler& assembler,
                                         UploadReservation& ticket) const;

  const ServerOptions& options_;
  SessionStore* store_;
  UploadWatch* uploads_;
  const Clock* clock_;
};

}  // namespace meshgauge::server
