#include "server/upload_watch.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

absl::StatusOr<int64_t> UploadWatch::Start(grpc::ServerContextBase* ctx) {
  return Add(ctx, /*discard=*/false);
}

absl::StatusOr<int64_t> UploadWatch::StartDiscard(
    grpc::ServerContextBase* ctx) {
  return Add(ctx, /*discard=*/true);
}

absl::StatusOr<int64_t> UploadWatch::Add(grpc::ServerContextBase* ctx,
                                         bool discard) {
  absl::MutexLock lock(&mu_);
  if (discard ? discards_ >= kMaxDiscards
              : std::ssize(uploads_) - discards_ >=
                    options_.max_concurrent_uploads) {
    return absl::ResourceExhaustedError(
        discard ? absl::StrCat(kMaxDiscards, " refused uploads are being read")
                : absl::StrCat(options_.max_concurrent_uploads,
                               " uploads are already in flight "
                               "(--max_concurrent_uploads); retry later"));
  }
  const int64_t id = next_++;
  const double now = clock_->NowSeconds();
  uploads_.emplace(id, Entry{.ctx = ctx,
                             .start = now,
                             .last = now,
                             .bytes = 0,
                             .aborted = false,
                             .discard = discard});
  discards_ += discard;
  return id;
}

absl::Status UploadWatch::Touch(int64_t id, int64_t bytes) {
  absl::MutexLock lock(&mu_);
  auto it = uploads_.find(id);
  if (it == uploads_.end()) return absl::OkStatus();
  Entry& e = it->second;
  const double now = clock_->NowSeconds();
  e.last = now;
  e.bytes += bytes;
  ++e.messages;
  const double elapsed = now - e.start;
  if (e.discard) {
    if (e.bytes <= kMaxDiscardBytes && elapsed <= kMaxDiscardSeconds) {
      return absl::OkStatus();
    }
    return absl::OutOfRangeError(
        absl::StrCat("a refused upload's remainder reached ", e.bytes,
                     " bytes in ", elapsed, " s"));
  }
  // An eighth of the message limits when they are small.
  const int64_t min_average =
      std::min({kMinAverageMessageBytes, options_.max_message_bytes / 8,
                options_.max_upload_message_bytes / 8});
  if (e.messages > kTinyMessagesAllowed &&
      e.bytes < min_average * e.messages) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "CreateSession: ", e.messages, " messages averaging ",
        e.bytes / e.messages, " bytes: send chunks of at least ", min_average,
        " bytes on average"));
  }
  if (elapsed > options_.upload_deadline_seconds) {
    return absl::DeadlineExceededError(absl::StrCat(
        "CreateSession: the upload is still running after ",
        options_.upload_deadline_seconds, " s (--upload_deadline_seconds)"));
  }
  if (elapsed > options_.upload_idle_seconds &&
      e.bytes < options_.upload_min_bytes_per_second * elapsed) {
    return absl::DeadlineExceededError(absl::StrCat(
        "CreateSession: the upload sent ", e.bytes, " bytes in ", elapsed,
        " s, below the minimum of ", options_.upload_min_bytes_per_second,
        " bytes/s (--upload_min_bytes_per_second)"));
  }
  return absl::OkStatus();
}

void UploadWatch::Received(int64_t id) {
  absl::MutexLock lock(&mu_);
  if (auto it = uploads_.find(id); it != uploads_.end()) {
    it->second.received = true;
  }
}

absl::Status UploadWatch::Finish(int64_t id) {
  absl::MutexLock lock(&mu_);
  auto it = uploads_.find(id);
  if (it == uploads_.end()) return absl::OkStatus();
  const bool aborted = it->second.aborted;
  discards_ -= it->second.discard;
  uploads_.erase(it);
  if (!aborted) return absl::OkStatus();
  return absl::DeadlineExceededError(
      absl::StrCat("CreateSession: the upload was idle for more than ",
                   options_.upload_idle_seconds, " s (--upload_idle_seconds)"));
}

std::vector<std::string> UploadWatch::AbortIdle() {
  absl::MutexLock lock(&mu_);
  const double now = clock_->NowSeconds();
  std::vector<std::string> aborted;
  for (auto& [id, e] : uploads_) {
    if (e.aborted || e.received) continue;
    const bool idle = now - e.last > options_.upload_idle_seconds;
    if (!idle && !(e.discard && now - e.start > kMaxDiscardSeconds)) continue;
    e.aborted = true;
    aborted.push_back(
        e.discard
            ? absl::StrCat("a refused upload's remainder was cancelled after ",
                           now - e.start, " s and ", e.bytes, " bytes")
            : absl::StrCat("an upload was cancelled: silent for ",
                           now - e.last, " s (--upload_idle_seconds ",
                           options_.upload_idle_seconds, ") after ", e.bytes,
                           " bytes in ", now - e.start, " s"));
  }
  return aborted;
}

void UploadWatch::CancelAborted() {
  absl::MutexLock lock(&mu_);
  // An entry lives until its call's Finish, so its context is alive here.
  for (auto& [id, e] : uploads_) {
    if (!e.aborted || e.cancelled) continue;
    e.ctx->TryCancel();
    e.cancelled = true;
  }
}

}  // namespace meshgauge::server
