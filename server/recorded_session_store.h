// Sessions defined by external records (--session_store, e.g. Redis) and
// shared by every replica; this process caches their evaluators and passes
// per generation: see session_store.h.
#pragma once

#include <memory>

#include "server/session_cache.h"
#include "server/session_records.h"

namespace meshgauge::server {

class RecordedSessionStore final : public SessionCache {
 public:
  // options, metrics and clock must outlive the store; records not null.
  RecordedSessionStore(const ServerOptions& options, Metrics* metrics,
                       const Clock* clock,
                       std::unique_ptr<SessionRecords> records);

  absl::StatusOr<std::shared_ptr<Session>> Create(
      const std::string& tenant, std::string id, RepairedMesh mesh,
      UploadReservation ticket) override;
  // The cached session at the record's generation, loading the record on a
  // miss (handing it this replica's pass of an earlier generation).
  using SessionStore::Get;
  absl::StatusOr<std::shared_ptr<Session>> Get(const std::string& tenant,
                                               const std::string& id,
                                               bool touch) override;
  absl::Status Delete(const std::string& tenant,
                      const std::string& id) override;
  absl::StatusOr<wire::UpdateResult> UpdatePositions(
      const std::string& tenant, const std::shared_ptr<Session>& session,
      int64_t expected_generation, const std::vector<int32_t>& indices,
      const std::vector<Vec3>& positions,
      const UpdateControl& control) override;
  absl::StatusOr<std::vector<SessionSnapshot>> List(
      const std::string& tenant, const std::string& page_token, int page_size,
      std::string* next_token) override;

 private:
  absl::Status UploadClaimed(const std::string& tenant,
                             const std::string& token, int64_t bytes) override;
  void UploadRenewed(const std::string& tenant,
                     const std::string& token) override;
  void UploadReleased(const std::string& tenant,
                      const std::string& token) override;
  RecordLimits Limits() const;

  const std::unique_ptr<SessionRecords> records_;
};

}  // namespace meshgauge::server
