#include "server/session_store.h"

namespace meshgauge::server {

UploadReservation& UploadReservation::operator=(
    UploadReservation&& o) noexcept {
  if (this != &o) {
    if (ledger_) ledger_->ReleaseUpload(claim_);
    ledger_ = std::exchange(o.ledger_, nullptr);
    claim_ = std::exchange(o.claim_, {});
  }
  return *this;
}

UploadReservation::~UploadReservation() {
  if (ledger_) ledger_->ReleaseUpload(claim_);
}

absl::Status UploadReservation::Arrived(int64_t bytes) {
  return ledger_ ? ledger_->ArriveUpload(claim_, bytes) : absl::OkStatus();
}

absl::Status UploadReservation::GrowTo(int64_t bytes) {
  return ledger_ ? ledger_->GrowUpload(claim_, bytes) : absl::OkStatus();
}

UploadClaim UploadReservation::HandOver() {
  ledger_ = nullptr;
  return std::exchange(claim_, {});
}

}  // namespace meshgauge::server
