#include "server/upload_watch.h"

#include "absl/strings/str_cat.h"

namespace meshgauge::server {

absl::StatusOr<int64_t> UploadWatch::Start(grpc::ServerContext* ctx) {
  std::lock_guard<std::mutex> lock(mu_);
  if (std::ssize(uploads_) >= max_) {
    return absl::ResourceExhaustedError(absl::StrCat(
        max_,
        " uploads are already in flight (--max_concurrent_uploads); "
        "retry later"));
  }
  const int64_t id = next_++;
  uploads_.emplace(id, Entry{ctx, clock_->NowSeconds()});
  return id;
}

void UploadWatch::Touch(int64_t id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = uploads_.find(id);
  if (it != uploads_.end()) it->second.last = clock_->NowSeconds();
}

bool UploadWatch::Finish(int64_t id) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = uploads_.find(id);
  if (it == uploads_.end()) return false;
  const bool aborted = it->second.aborted;
  uploads_.erase(it);
  return aborted;
}

int UploadWatch::AbortIdle() {
  std::lock_guard<std::mutex> lock(mu_);
  const double now = clock_->NowSeconds();
  int n = 0;
  for (auto& [id, e] : uploads_) {
    if (!e.aborted && now - e.last > idle_seconds_) {
      e.aborted = true;
      e.ctx->TryCancel();
      ++n;
    }
  }
  return n;
}

}  // namespace meshgauge::server
