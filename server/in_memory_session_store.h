// The sessions of this process alone (no --session_store): see
// session_store.h.
#pragma once

#include "server/session_cache.h"

namespace meshgauge::server {

class InMemorySessionStore final : public SessionCache {
 public:
  // options, metrics and clock must outlive the store.
  InMemorySessionStore(const ServerOptions& options, Metrics* metrics,
                       const Clock* clock);

  absl::StatusOr<std::shared_ptr<Session>> Create(
      const std::string& tenant, std::string id, RepairedMesh mesh,
      UploadReservation ticket) override;
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
};

}  // namespace meshgauge::server
