// Slots for computations (ray passes, sensitivities, checks), so that one
// tenant cannot crowd the others out: each tenant runs at most
// --max_computations_per_tenant at once (its further calls queue), and when
// all --max_concurrent_computations slots are taken, a freed slot goes to
// the tenants with waiting calls in turn (round robin; each tenant's calls
// in arrival order). An outside tester saw another tenant's small call go
// from 4 ms to 304 ms while one tenant ran 32 passes: with a cap of two
// per tenant the small call shares the cores with two passes, not 32.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"

namespace meshgauge::server {

class ComputeSlots {
 public:
  // Both limits >= 1.
  ComputeSlots(int per_tenant, int total)
      : per_tenant_(per_tenant), total_(total) {}

  // A slot held until destroyed.
  class Slot {
   public:
    Slot() = default;
    Slot(Slot&& other) noexcept { *this = std::move(other); }
    Slot& operator=(Slot&& other) noexcept {
      Release();
      owner_ = other.owner_;
      tenant_ = std::move(other.tenant_);
      other.owner_ = nullptr;
      return *this;
    }
    ~Slot() { Release(); }
    // Gives the slot back early (a stream's values are sent without one).
    void Release() {
      if (owner_ != nullptr) owner_->Give(tenant_);
      owner_ = nullptr;
    }

   private:
    friend class ComputeSlots;
    ComputeSlots* owner_ = nullptr;
    std::string tenant_;
  };

  // Waits for a slot for `tenant`, polling `abandoned` (the caller left or
  // its deadline passed) about every 50 ms. Errors: CANCELLED, naming the
  // wait, when abandoned while queued.
  absl::StatusOr<Slot> Take(const std::string& tenant,
                            const std::function<bool()>& abandoned);

  // Calls running and waiting now (for tests and diagnostics).
  int running() const;
  int waiting() const;

 private:
  void Give(const std::string& tenant);
  // Whether the call `ticket` of `tenant` may start now.
  bool MayStart(const std::string& tenant, uint64_t ticket) const
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // Takes `ticket` of `tenant` out of the queue (it leaves or starts).
  void Dequeue(const std::string& tenant, uint64_t ticket)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const int per_tenant_, total_;
  mutable absl::Mutex mu_;
  absl::CondVar cv_;
  int running_ ABSL_GUARDED_BY(mu_) = 0;
  std::map<std::string, int> running_by_tenant_ ABSL_GUARDED_BY(mu_);
  // Waiting calls per tenant, in arrival order, and the tenants in the
  // order their turn comes.
  std::map<std::string, std::deque<uint64_t>> queued_ ABSL_GUARDED_BY(mu_);
  std::deque<std::string> turns_ ABSL_GUARDED_BY(mu_);
  uint64_t next_ticket_ ABSL_GUARDED_BY(mu_) = 0;
};

}  // namespace meshgauge::server
