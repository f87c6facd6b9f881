// Uploads in flight and their last activity: caps how many run at once and
// aborts (TryCancel) the ones idle longer than --upload_idle_seconds, so a
// client that opens an upload and goes silent holds neither a thread nor
// its reservation for long.
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstdint>
#include <map>
#include <mutex>

#include "absl/status/statusor.h"
#include "server/clock.h"

namespace meshgauge::server {

class UploadWatch {
 public:
  UploadWatch(int64_t max_concurrent, double idle_seconds, const Clock* clock)
      : max_(max_concurrent), idle_seconds_(idle_seconds), clock_(clock) {}

  // Registers an upload; RESOURCE_EXHAUSTED when max_concurrent are running.
  absl::StatusOr<int64_t> Start(grpc::ServerContext* ctx);
  void Touch(int64_t id);
  // True when Abort cancelled this upload for idling.
  bool Finish(int64_t id);
  // Cancels every upload idle longer than the limit; returns how many.
  int AbortIdle();
  double idle_seconds() const { return idle_seconds_; }

 private:
  struct Entry {
    grpc::ServerContext* ctx;
    double last;
    bool aborted = false;
  };
  const int64_t max_;
  const double idle_seconds_;
  const Clock* clock_;
  std::mutex mu_;
  int64_t next_ = 0;
  std::map<int64_t, Entry> uploads_;
};

}  // namespace meshgauge::server
