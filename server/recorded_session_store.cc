#include "server/recorded_session_store.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/ray_scene.h"

namespace meshgauge::server {

RecordedSessionStore::RecordedSessionStore(
    const ServerOptions& options, Metrics* metrics, const Clock* clock,
    std::unique_ptr<SessionRecords> records)
    : SessionCache(options, metrics, clock, /*records_hold_limits=*/true),
      records_(std::move(records)) {}

RecordLimits RecordedSessionStore::Limits() const {
  return {options_.max_sessions, options_.SessionsPerTenant(),
          options_.BudgetPerTenant()};
}

absl::Status RecordedSessionStore::UploadClaimed(const std::string& tenant,
                                                 const std::string& token,
                                                 int64_t bytes) {
  return records_->Reserve(tenant, token, bytes, Limits(), ClaimSeconds());
}

void RecordedSessionStore::UploadRenewed(const std::string& tenant,
                                         const std::string& token) {
  records_->Renew(tenant, token, ClaimSeconds());
}

void RecordedSessionStore::UploadReleased(const std::string& tenant,
                                          const std::string& token) {
  records_->Unreserve(tenant, token);
}

absl::StatusOr<std::shared_ptr<Session>> RecordedSessionStore::Create(
    const std::string& tenant, std::string id, RepairedMesh mesh,
    UploadReservation ticket) {
  const bool chosen = id.empty();
  if (!chosen && !ValidSessionId(id)) return InvalidSessionId(id);
  // The record first: it decides existence and the limits, for all
  // replicas at once.
  if (chosen) id = RandomSessionId();
  SessionRecord record;
  record.mesh = mesh.mesh;
  // The BVH is built on first use, after the record was accepted.
  auto session = std::make_shared<Session>(id, std::move(mesh), options_,
                                           metrics_, clock_->NowSeconds());
  record.info = session->Info();
  record.incarnation = session->incarnation();
  absl::Status s =
      records_->Create(tenant, record, Limits(), ticket.claim().token);
  for (int retry = 0; chosen && retry < 3 && absl::IsAlreadyExists(s);
       ++retry) {
    record.info.session_id = RandomSessionId();
    s = records_->Create(tenant, record, Limits(), ticket.claim().token);
  }
  if (!s.ok()) return s;
  if (record.info.session_id != id) {
    session = std::make_shared<Session>(record, options_, metrics_,
                                        clock_->NowSeconds());
  }
  absl::MutexLock lock(&mu_);
  ConsumeLocked(ticket);  // the record holds the claim now.
  sessions_[Key{tenant, record.info.session_id}] = session;
  MakeRoomLocked(session.get());
  PublishLocked();
  return session;
}

absl::StatusOr<std::shared_ptr<Session>> RecordedSessionStore::Get(
    const std::string& tenant, const std::string& id, bool touch) {
  if (!ValidSessionId(id)) return SessionNotFound(id);
  auto version = records_->Version(tenant, id, touch);
  if (!version.ok()) {
    if (absl::IsNotFound(version.status())) {
      absl::MutexLock lock(&mu_);
      sessions_.erase({tenant, id});  // deleted or expired elsewhere.
    }
    return version.status();
  }
  // This replica's ray pass of the session at an earlier generation, which
  // the restored session's next pass reuses (the pass records its
  // positions; docs/numerics.md, "Incremental passes").
  std::shared_ptr<const CachedPass> earlier_pass;
  {
    absl::MutexLock lock(&mu_);
    auto it = sessions_.find({tenant, id});
    if (it != sessions_.end() &&
        it->second->incarnation() == version->incarnation) {
      if (it->second->generation() == version->generation) {
        if (touch) it->second->Touch(clock_->NowSeconds());
        metrics_->RecordSessionCache(true, 0);
        return it->second;
      }
      earlier_pass = it->second->CachedPassOfAnyGeneration();
    }
  }
  // A miss: first use on this replica, evicted, updated elsewhere, or
  // deleted and created again elsewhere.
  const double start = clock_->NowSeconds();
  const Stopwatch wall;
  auto record = records_->Load(tenant, id);
  if (!record.ok()) return record.status();
  auto session =
      std::make_shared<Session>(std::move(*record), options_, metrics_, start);
  if (auto reader = session->Read(); !reader.ok()) return reader.status();
  if (earlier_pass) session->StorePass(std::move(earlier_pass));
  metrics_->RecordSessionCache(false, wall.Seconds());
  {
    absl::MutexLock lock(&mu_);
    sessions_[Key{tenant, id}] = session;
    PublishLocked();
  }
  EnforceBudget(session.get());
  return session;
}

absl::Status RecordedSessionStore::Delete(const std::string& tenant,
                                          const std::string& id) {
  absl::Status s =
      ValidSessionId(id) ? records_->Delete(tenant, id) : SessionNotFound(id);
  absl::MutexLock lock(&mu_);
  if (s.ok() || absl::IsNotFound(s)) sessions_.erase({tenant, id});
  PublishLocked();
  return s;
}

absl::StatusOr<wire::UpdateResult> RecordedSessionStore::UpdatePositions(
    const std::string& tenant, const std::shared_ptr<Session>& session,
    int64_t expected_generation, const std::vector<int32_t>& indices,
    const std::vector<Vec3>& positions, const UpdateControl& control) {
  Session& s = *session;
  const std::string& id = s.id();
  std::lock_guard<std::mutex> update_lock(s.update_mutex());
  // One generation ahead may be this very update, applied before its reply
  // was lost: the record's compare-and-set recognises it.
  const bool maybe_retry = s.generation() == expected_generation + 1;
  if (s.generation() != expected_generation && !maybe_retry) {
    return GenerationMismatch(id, s.generation(), expected_generation,
                              "update");
  }
  // The new positions of every vertex, validated before the record changes.
  std::vector<Vec3> all;
  {
    auto reader = s.Read();
    if (!reader.ok()) return reader.status();
    Mesh moved = reader->evaluator->mesh();
    if (indices.empty()) {
      // Checked here, against this incarnation's mesh: the caller's count
      // check may have seen another incarnation (deleted and re-created in
      // between), and extra points would pass validation as unused
      // vertices, then corrupt the record.
      if (absl::Status c = CheckPointCount(std::ssize(positions),
                                           std::ssize(moved.positions), false);
          !c.ok()) {
        return c;
      }
      moved.positions = positions;
    } else if (absl::Status v =
                   MoveVertices(indices, positions, &moved.positions);
               !v.ok()) {
      return v;
    }
    // What the evaluator would refuse after the commit: the mesh's rules
    // and the ray tracer's range (a refused update must change nothing).
    absl::Status v = ValidateMesh(moved);
    if (v.ok()) v = CheckTraceable(moved);
    if (!v.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("position update rejected: ", v.message()));
    }
    all = std::move(moved.positions);
  }
  // A caller that gave up while it waited is never applied: checked before
  // the record moves (after it, the update is made whatever the wait).
  if (control.cancelled && control.cancelled()) {
    return absl::CancelledError("the caller left before the update's turn");
  }
  if (std::chrono::system_clock::now() >= control.deadline) {
    return absl::DeadlineExceededError(
        "the update's deadline passed before its turn; nothing was changed");
  }
  // The positions were checked against this incarnation's mesh: the record
  // takes them only if it is still that incarnation.
  auto committed = records_->CommitPositions(
      tenant, id, {expected_generation, s.incarnation()}, all,
      IsBvhBase(expected_generation + 1, options_.rebuild_every_updates));
  if (!committed.ok()) return committed.status();
  if (maybe_retry) {
    return wire::UpdateResult{
        .generation = *committed,
        .refit = !IsBvhBase(*committed, options_.rebuild_every_updates)};
  }
  auto outcome = s.UpdatePositions(expected_generation, {}, all);
  if (!outcome.ok()) {
    // The record moved on; this cache entry (if still this one) is stale.
    absl::MutexLock lock(&mu_);
    if (auto it = sessions_.find({tenant, id});
        it != sessions_.end() && it->second == session) {
      sessions_.erase(it);
    }
  }
  return outcome;
}

absl::StatusOr<std::vector<SessionSnapshot>> RecordedSessionStore::List(
    const std::string& tenant, const std::string& page_token, int page_size,
    std::string* next_token) {
  auto listed = records_->List(tenant, page_token, page_size, next_token);
  if (!listed.ok()) return listed.status();
  const double now = clock_->NowSeconds();
  std::vector<SessionSnapshot> out;
  absl::MutexLock lock(&mu_);
  for (const RecordSummary& record : *listed) {
    const wire::SessionInfo& info = record.info;
    SessionSnapshot s;
    auto it = sessions_.find({tenant, info.session_id});
    if (it != sessions_.end() &&
        it->second->incarnation() == record.incarnation &&
        it->second->generation() == info.generation) {
      s = it->second->Snapshot();  // with this replica's BVH counts.
    } else {
      s.info = info;
    }
    s.last_used = now - info.idle_seconds;
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace meshgauge::server
