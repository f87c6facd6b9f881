// Uploads in flight and their progress: caps how many run at once, aborts
// (TryCancel: the client sees CANCELLED) the ones idle longer than
// --upload_idle_seconds, and refuses the next message of one running longer
// than --upload_deadline_seconds or, after its first --upload_idle_seconds,
// averaging fewer than --upload_min_bytes_per_second (DEADLINE_EXCEEDED);
// so a client that opens an upload and goes silent, or trickles bytes,
// holds neither a thread nor its reservation for long. It also bounds the
// reading of refused uploads' remainders (StartDiscard).
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "server/clock.h"
#include "server/server_options.h"

namespace meshgauge::server {

// Past its first kTinyMessagesAllowed messages, an upload's messages must
// average kMinAverageMessageBytes (an eighth of --max_message_bytes or
// --max_upload_message_bytes when smaller): a message costs the server about
// 50-80 us
// whatever its size, so a trickle of tiny messages above the minimum rate
// would otherwise hold a core (the clients send chunks of 64k vertices or
// 1 MiB of file).
inline constexpr int64_t kTinyMessagesAllowed = 16;
inline constexpr int64_t kMinAverageMessageBytes = 4096;

// Bounds on the remainder of a refused upload read and dropped before the
// refusal is sent (StartDiscard): at most kMaxDiscards at once, each at
// most kMaxDiscardBytes and kMaxDiscardSeconds.
inline constexpr int kMaxDiscards = 4;
inline constexpr int64_t kMaxDiscardBytes = int64_t{64} << 20;
inline constexpr double kMaxDiscardSeconds = 5;

class UploadWatch {
 public:
  // options and clock must outlive the watch.
  UploadWatch(const ServerOptions& options, const Clock* clock)
      : options_(options), clock_(clock) {}

  // Registers an upload; RESOURCE_EXHAUSTED when max_concurrent are running.
  absl::StatusOr<int64_t> Start(grpc::ServerContextBase* ctx);
  // Registers the remainder of a refused upload, to be read and dropped
  // (see UploadReception::DiscardRest); RESOURCE_EXHAUSTED when
  // kMaxDiscards are running. Discards do not count against
  // max_concurrent_uploads, so refused callers take no upload slot.
  absl::StatusOr<int64_t> StartDiscard(grpc::ServerContextBase* ctx);
  // A message of `bytes` arrived. DEADLINE_EXCEEDED, naming the flag, when
  // the upload is past its deadline or below the minimum rate;
  // RESOURCE_EXHAUSTED when its messages are too small on average
  // (kMinAverageMessageBytes); for a discard, OUT_OF_RANGE past
  // kMaxDiscardBytes or kMaxDiscardSeconds.
  absl::Status Touch(int64_t id, int64_t bytes);
  // The upload's last message arrived: from now on the server builds and
  // checks the mesh, which is not the client's idleness, so AbortIdle and
  // the rate and deadline checks leave it alone.
  void Received(int64_t id);
  // OK, or DEADLINE_EXCEEDED when AbortIdle aborted this upload.
  absl::Status Finish(int64_t id);
  // Marks aborted every upload idle longer than the limit (still
  // receiving), and every discard older than kMaxDiscardSeconds (silent or
  // not); returns one line for the server's log per upload aborted, naming
  // the flag and what the client sent. CancelAborted then cancels them, so
  // that the line is logged before the call ends. (A cancelled call carries
  // no status of the server's: the client sees CANCELLED.)
  std::vector<std::string> AbortIdle();
  // Cancels the calls of the uploads AbortIdle aborted that are still open.
  void CancelAborted();

 private:
  struct Entry {
    grpc::ServerContextBase* ctx;
    double start, last;
    int64_t bytes = 0;
    int64_t messages = 0;
    bool aborted = false;
    bool cancelled = false;  // CancelAborted cancelled the call.
    bool discard = false;
    bool received = false;  // Received: the stream was read to its end.
  };
  absl::StatusOr<int64_t> Add(grpc::ServerContextBase* ctx, bool discard);

  const ServerOptions& options_;
  const Clock* clock_;
  absl::Mutex mu_;
  int64_t next_ ABSL_GUARDED_BY(mu_) = 0;
  std::map<int64_t, Entry> uploads_ ABSL_GUARDED_BY(mu_);
  // Entries of uploads_ that are discards.
  int64_t discards_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace meshgauge::server
