#include "server/session.h"

#include <algorithm>
#include <random>

#include "absl/strings/str_cat.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/hub_fans.h"
#include "server/session_messages.h"

namespace meshgauge::server {
namespace {

// What a record keeps of the diagnostics at upload.
MeshDiagnostics RecordedDiagnostics(const wire::SessionInfo& info) {
  MeshDiagnostics d;
  d.closed = info.closed;
  d.warnings = info.warnings;
  return d;
}

}  // namespace

std::string NewIncarnation() {
  static thread_local std::random_device device;
  std::string out;
  for (int i = 0; i < 4; ++i)
    absl::StrAppend(&out, absl::Hex(device(), absl::kZeroPad8));
  return out;
}

int64_t Session::EstimateBytes(int64_t vertices, int64_t faces,
                               int64_t primitives) {
  // Mesh (positions, faces, regions), topology (primitives, incidences,
  // directions), the vertices' Morton order, Embree vertex/index buffers and
  // BVH nodes (Embree's memory monitor: 41.0 MB for igea's 268,686
  // triangles, buffers included).
  return vertices * (24 + 8 + 1 + 4 + 32) + faces * (20 + 4 + 12) +
         primitives * (16 + 12 + 16 + 136);
}

int64_t Session::EstimateBaseBytes(const Mesh& mesh) {
  int64_t prims = 0;
  for (const Face& f : mesh.faces) prims += f.size == 4 ? 2 : 1;
  // The ray tracer's own trees for hub fans, when the mesh has any.
  return EstimateBytes(mesh.num_vertices(), mesh.num_faces(), prims) +
         HubFans::EstimateBytes(mesh);
}

Session::Session(std::string id, RepairedMesh mesh,
                 const ServerOptions& options, Metrics* metrics, double now)
    : id_(std::move(id)),
      incarnation_(NewIncarnation()),
      options_(options),
      metrics_(metrics),
      dimension_(mesh.mesh.dimension),
      num_vertices_(mesh.mesh.num_vertices()),
      num_faces_(mesh.mesh.num_faces()),
      signed_volume_(mesh.signed_volume),
      diagnostics_(std::move(mesh.diagnostics)),
      base_bytes_(EstimateBaseBytes(mesh.mesh)),
      pending_mesh_(std::move(mesh.mesh)),
      last_used_(now) {}

Session::Session(SessionRecord record, const ServerOptions& options,
                 Metrics* metrics, double now)
    : id_(record.info.session_id),
      incarnation_(std::move(record.incarnation)),
      options_(options),
      metrics_(metrics),
      dimension_(record.info.dimension),
      num_vertices_(record.info.num_vertices),
      num_faces_(record.info.num_faces),
      signed_volume_(record.info.signed_volume),
      diagnostics_(RecordedDiagnostics(record.info)),
      base_bytes_(record.info.memory_bytes),
      pending_mesh_(std::move(record.mesh)),
      generation_(record.info.generation),
      last_used_(now) {
  if (!record.base_positions.empty()) {
    pending_positions_ = std::move(pending_mesh_.positions);
    pending_mesh_.positions = std::move(record.base_positions);
  }
}

wire::SessionInfo Session::Info() const {
  wire::SessionInfo info;
  info.session_id = id_;
  info.dimension = dimension_;
  info.num_vertices = num_vertices_;
  info.num_faces = num_faces_;
  info.memory_bytes = base_bytes_;
  info.signed_volume = signed_volume_;
  info.closed = diagnostics_.closed;
  info.warnings = diagnostics_.warnings;
  info.generation = generation_;
  return info;
}

absl::Status Session::EnsureEvaluator() {
  if (evaluator_) return absl::OkStatus();
  const Stopwatch watch;
  const bool refit = !pending_positions_.empty();
  auto ev = SdfEvaluator::Create(
      std::move(pending_mesh_),
      {.bvh_policy = BvhUpdatePolicy::kRefit,
       .rebuild_every_updates = options_.rebuild_every_updates,
       .generation = refit ? generation_ - 1 : generation_.load()});
  if (!ev.ok()) return ev.status();
  metrics_->RecordBvhBuild(watch.Seconds());
  if (refit) {
    // Base positions are a past generation: refit to the current ones (the
    // current generation is not a base, or they would be the base).
    const Stopwatch refit_watch;
    if (absl::Status s = (*ev)->UpdatePositions(pending_positions_); !s.ok()) {
      return s;
    }
    pending_positions_ = {};
    metrics_->RecordBvhRefit(refit_watch.Seconds());
  }
  evaluator_ = std::move(*ev);
  published_ = evaluator_.get();
  return absl::OkStatus();
}

absl::StatusOr<Session::Reader> Session::Read() {
  {
    std::shared_lock<WriterFirstMutex> lock(mu_);
    if (evaluator_) return Reader{std::move(lock), evaluator_.get()};
  }
  {
    std::unique_lock<WriterFirstMutex> lock(mu_);
    if (absl::Status s = EnsureEvaluator(); !s.ok()) return s;
  }
  std::shared_lock<WriterFirstMutex> lock(mu_);
  return Reader{std::move(lock), evaluator_.get()};
}

absl::StatusOr<wire::UpdateResult> Session::UpdatePositions(
    int64_t expected_generation, absl::Span<const int32_t> indices,
    absl::Span<const Vec3> positions, const UpdateControl& control) {
  if (control.deadline == std::chrono::system_clock::time_point::max()) {
    mu_.lock();
  } else if (!mu_.try_lock_until(control.deadline)) {
    return absl::DeadlineExceededError(absl::StrCat(
        "session '", id_,
        "': the update's deadline passed while computations already running "
        "on it finished; nothing was changed"));
  }
  const AdoptedWriterLock lock(&mu_);
  if (control.cancelled && control.cancelled()) {
    return absl::CancelledError(
        absl::StrCat("session '", id_,
                     "': the caller left before the update's turn; "
                     "nothing was changed"));
  }
  if (absl::Status s = EnsureEvaluator(); !s.ok()) return s;
  if (expected_generation != evaluator_->generation()) {
    return GenerationMismatch(id_, evaluator_->generation(),
                              expected_generation, "update");
  }
  const Stopwatch watch;
  const int64_t builds = evaluator_->builds();
  absl::Status s = indices.empty()
                       ? evaluator_->UpdatePositions(positions)
                       : evaluator_->UpdatePositions(indices, positions);
  if (!s.ok()) return s;
  wire::UpdateResult out;
  out.refit = evaluator_->builds() == builds;
  out.bvh_seconds = watch.Seconds();
  if (out.refit) {
    metrics_->RecordBvhRefit(out.bvh_seconds);
  } else {
    metrics_->RecordBvhBuild(out.bvh_seconds);
  }
  out.generation = evaluator_->generation();
  generation_ = out.generation;
  // The cached pass stays (still counted in memory_bytes): the next pass
  // with its parameters reuses its rays (LatestPass).
  return out;
}

std::shared_ptr<const CachedPass> Session::FindPass(const SdfParams& params,
                                                    int64_t generation) const {
  absl::MutexLock lock(&cache_mu_);
  if (cache_ && cache_->generation == generation && cache_->params == params) {
    return cache_;
  }
  return nullptr;
}

std::shared_ptr<const CachedPass> Session::LatestPass(
    const SdfParams& params) const {
  absl::MutexLock lock(&cache_mu_);
  if (cache_ && cache_->params == params) return cache_;
  return nullptr;
}

std::shared_ptr<const CachedPass> Session::CachedPassOfAnyGeneration() const {
  absl::MutexLock lock(&cache_mu_);
  return cache_;
}

void Session::StorePass(std::shared_ptr<const CachedPass> pass) {
  absl::MutexLock lock(&cache_mu_);
  cache_bytes_ = pass->bytes;
  cache_ = std::move(pass);
}

SessionSnapshot Session::Snapshot() const {
  SessionSnapshot s;
  s.info = Info();
  s.info.memory_bytes = memory_bytes();
  if (const SdfEvaluator* ev = published_.load()) {
    s.info.bvh_builds = ev->builds();
    s.info.bvh_refits = ev->refits();
  }
  s.last_used = last_used_;
  return s;
}

wire::SessionInfo ToSessionInfo(const SessionSnapshot& s, double now) {
  wire::SessionInfo out = s.info;
  out.idle_seconds = std::max(0.0, now - s.last_used);
  return out;
}

}  // namespace meshgauge::server
