#include "server/compute_slots.h"

#include <algorithm>

#include "absl/time/time.h"

namespace meshgauge::server {

bool ComputeSlots::MayStart(const std::string& tenant, uint64_t ticket) const {
  if (running_ >= total_) return false;
  auto mine = running_by_tenant_.find(tenant);
  if (mine != running_by_tenant_.end() && mine->second >= per_tenant_) {
    return false;
  }
  // First in its tenant's queue, and its tenant's turn: the first tenant in
  // `turns_` that may run now (others at their cap are skipped).
  if (queued_.at(tenant).front() != ticket) return false;
  for (const std::string& t : turns_) {
    auto r = running_by_tenant_.find(t);
    if (r != running_by_tenant_.end() && r->second >= per_tenant_) continue;
    return t == tenant;
  }
  return false;
}

void ComputeSlots::Dequeue(const std::string& tenant, uint64_t ticket) {
  std::deque<uint64_t>& q = queued_[tenant];
  q.erase(std::find(q.begin(), q.end(), ticket));
  if (q.empty()) {
    queued_.erase(tenant);
    turns_.erase(std::find(turns_.begin(), turns_.end(), tenant));
  }
}

absl::StatusOr<ComputeSlots::Slot> ComputeSlots::Take(
    const std::string& tenant, const std::function<bool()>& abandoned) {
  absl::MutexLock lock(&mu_);
  const uint64_t ticket = next_ticket_++;
  std::deque<uint64_t>& queue = queued_[tenant];
  if (queue.empty()) turns_.push_back(tenant);
  queue.push_back(ticket);
  while (!MayStart(tenant, ticket)) {
    cv_.WaitWithTimeout(&mu_, absl::Milliseconds(50));
    if (MayStart(tenant, ticket)) break;
    if (abandoned && abandoned()) {
      Dequeue(tenant, ticket);
      cv_.SignalAll();
      return absl::CancelledError(
          "the call left while it waited for a computation slot "
          "(--max_computations_per_tenant, --max_concurrent_computations)");
    }
  }
  // Started: out of the queue; the tenant's turn moves to the back if it
  // has more calls waiting.
  Dequeue(tenant, ticket);
  if (queued_.count(tenant) > 0) {
    turns_.erase(std::find(turns_.begin(), turns_.end(), tenant));
    turns_.push_back(tenant);
  }
  ++running_;
  ++running_by_tenant_[tenant];
  cv_.SignalAll();
  Slot slot;
  slot.owner_ = this;
  slot.tenant_ = tenant;
  return slot;
}

void ComputeSlots::Give(const std::string& tenant) {
  absl::MutexLock lock(&mu_);
  --running_;
  if (--running_by_tenant_[tenant] == 0) running_by_tenant_.erase(tenant);
  cv_.SignalAll();
}

int ComputeSlots::running() const {
  absl::MutexLock lock(&mu_);
  return running_;
}

int ComputeSlots::waiting() const {
  absl::MutexLock lock(&mu_);
  int n = 0;
  for (const auto& [tenant, queue] : queued_) n += static_cast<int>(queue.size());
  return n;
}

}  // namespace meshgauge::server
