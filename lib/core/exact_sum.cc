#include "lib/core/exact_sum.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace meshgauge {
namespace {

// GCC's and clang's 128-bit integer (__extension__: no -Wpedantic warning).
__extension__ typedef unsigned __int128 Uint128;

constexpr int kLimbBits = 32;
constexpr int64_t kLimbMask = (int64_t{1} << kLimbBits) - 1;
// Bits of the exponent offset: the value is limbs x 2^(bit - kBias).
constexpr int kBias = 1074;
constexpr uint32_t kMaxPending = uint32_t{1} << 30;
constexpr uint8_t kPlusInf = 1, kMinusInf = 2, kNaN = 4;

int32_t FloorDiv(int32_t a, int32_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

}  // namespace

void ExactSum::Cover(int32_t first, int32_t last) {
  if (limbs_.empty()) {
    base_ = first;
    limbs_.assign(last - first + 1, 0);
    return;
  }
  if (first < base_) {
    limbs_.insert(limbs_.begin(), base_ - first, 0);
    base_ = first;
  }
  const int32_t top = base_ + static_cast<int32_t>(limbs_.size()) - 1;
  if (last > top) limbs_.resize(limbs_.size() + (last - top), 0);
}

void ExactSum::Add(double x) {
  if (!std::isfinite(x)) {
    special_ |= std::isnan(x) ? kNaN : (x > 0 ? kPlusInf : kMinusInf);
    return;
  }
  if (x == 0) return;
  const uint64_t u = std::bit_cast<uint64_t>(x);
  const int exponent = static_cast<int>((u >> 52) & 0x7ff);
  uint64_t mantissa = u & ((uint64_t{1} << 52) - 1);
  // x = mantissa x 2^(offset - kBias), offset >= 0.
  int offset = 0;
  if (exponent != 0) {
    mantissa |= uint64_t{1} << 52;
    offset = exponent - 1;
  }
  const int32_t k = offset / kLimbBits;
  const Uint128 wide = static_cast<Uint128>(mantissa)
                                 << (offset % kLimbBits);
  const int64_t sign = (u >> 63) ? -1 : 1;
  Cover(k, k + 2);
  AddChunk(k, sign * static_cast<int64_t>(wide & kLimbMask));
  AddChunk(k + 1, sign * static_cast<int64_t>((wide >> 32) & kLimbMask));
  AddChunk(k + 2, sign * static_cast<int64_t>(wide >> 64));
  if (++pending_ >= kMaxPending) Normalize();
}

void ExactSum::Add(const ExactSum& other) {
  special_ |= other.special_;
  if (other.limbs_.empty()) return;
  ExactSum o = other;
  o.Normalize();
  if (o.limbs_.empty()) return;
  Normalize();
  Cover(o.base_, o.base_ + static_cast<int32_t>(o.limbs_.size()) - 1);
  for (size_t i = 0; i < o.limbs_.size(); ++i) {
    AddChunk(o.base_ + static_cast<int32_t>(i), o.limbs_[i]);
  }
  ++pending_;
}

void ExactSum::Normalize() {
  pending_ = 0;
  for (;;) {
    for (size_t i = 0; i + 1 < limbs_.size(); ++i) {
      const int64_t carry = limbs_[i] >> kLimbBits;  // floor
      limbs_[i] &= kLimbMask;
      limbs_[i + 1] += carry;
    }
    if (limbs_.empty()) return;
    const int64_t top = limbs_.back();
    if (top > -(int64_t{1} << kLimbBits) && top < (int64_t{1} << kLimbBits)) {
      break;
    }
    limbs_.push_back(0);  // the top limb's carry needs a limb of its own.
  }
  // Every limb but the top is in [0, 2^32); drop zero limbs at both ends.
  while (!limbs_.empty() && limbs_.back() == 0) limbs_.pop_back();
  size_t low = 0;
  while (low < limbs_.size() && limbs_[low] == 0) ++low;
  if (low > 0) {
    limbs_.erase(limbs_.begin(), limbs_.begin() + low);
    base_ += static_cast<int32_t>(low);
  }
  if (limbs_.empty()) base_ = 0;
}

bool ExactSum::IsZero() const {
  if (special_ != 0) return false;
  ExactSum copy = *this;
  copy.Normalize();
  return copy.limbs_.empty();
}

double ExactSum::Round() const {
  if ((special_ & kNaN) || special_ == (kPlusInf | kMinusInf)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  if (special_ != 0) {
    return special_ == kPlusInf ? std::numeric_limits<double>::infinity()
                                : -std::numeric_limits<double>::infinity();
  }
  ExactSum m = *this;
  m.Normalize();
  if (m.limbs_.empty()) return 0.0;
  const bool negative = m.limbs_.back() < 0;
  if (negative) {
    for (int64_t& limb : m.limbs_) limb = -limb;
    m.Normalize();
  }
  // m is positive: limbs in [0, 2^32), the top one nonzero. Its highest
  // set bit, counted from the bottom of the window:
  const int top_limb = static_cast<int>(m.limbs_.size()) - 1;
  const int high = top_limb * kLimbBits +
                   (63 - std::countl_zero(static_cast<uint64_t>(
                             m.limbs_[top_limb])));
  // The window's bits [lo, lo + n), n <= 64 (zeros below the window).
  auto bits = [&m](int lo, int n) {
    Uint128 acc = 0;
    const int first = FloorDiv(lo, kLimbBits);
    for (int i = first + 2; i >= first; --i) {
      acc <<= kLimbBits;
      if (i >= 0 && i < static_cast<int>(m.limbs_.size())) acc |= m.limbs_[i];
    }
    const int shift = lo - first * kLimbBits;
    return static_cast<uint64_t>((acc >> shift) &
                                 ((static_cast<Uint128>(1) << n) - 1));
  };
  const int absolute_base = m.base_ * kLimbBits;  // of window bit 0.
  double r;
  if (absolute_base + high < 53) {
    // At most 53 significant bits above 2^-1074: exact.
    r = std::ldexp(static_cast<double>(bits(0, high + 1)),
                   absolute_base - kBias);
  } else {
    // The top 53 bits, rounded half to even on the bits below them.
    const int lsb = high - 52;  // window bit of the mantissa's last bit.
    uint64_t mantissa = bits(lsb, 53);
    const bool round = bits(lsb - 1, 1) != 0;
    bool sticky = false;  // any bit below the round bit
    for (int i = 0; i < lsb - 1 && !sticky; i += kLimbBits) {
      sticky = bits(i, std::min(kLimbBits, lsb - 1 - i)) != 0;
    }
    if (round && (sticky || (mantissa & 1))) ++mantissa;
    r = std::ldexp(static_cast<double>(mantissa),
                   absolute_base + lsb - kBias);
  }
  return negative ? -r : r;
}

std::vector<double> ExactSum::Terms() const {
  const double head = Round();
  if (!std::isfinite(head) && special_ != 0) return {head};
  std::vector<double> terms;
  ExactSum rest = *this;
  while (!rest.IsZero()) {
    double t = rest.Round();
    // A value beyond the doubles' range: take the largest double off it.
    if (std::isinf(t)) t = std::copysign(std::numeric_limits<double>::max(), t);
    terms.push_back(t);
    rest.Add(-t);
  }
  return terms;
}

void ExactSums::Spill(int64_t i, double x) { spill_[i].Add(x); }

ExactSum ExactSums::Exact(int64_t i) const {
  ExactSum e;
  if (auto it = spill_.find(i); it != spill_.end()) e = it->second;
  e.Add(pairs_[i].hi);
  e.Add(pairs_[i].lo);
  return e;
}

double ExactSums::Round(int64_t i) const {
  // One IEEE addition rounds the exact sum of two doubles correctly.
  if (!spill_.contains(i)) return pairs_[i].hi + pairs_[i].lo;
  return Exact(i).Round();
}

std::vector<double> ExactSums::Terms(int64_t i) const {
  if (spill_.contains(i)) return Exact(i).Terms();
  const double hi = pairs_[i].hi, lo = pairs_[i].lo;
  const double r = hi + lo;
  if (!std::isfinite(r)) return Exact(i).Terms();
  const double r_lo = r - hi;
  const double rest = (hi - (r - r_lo)) + (lo - r_lo);  // hi + lo = r + rest
  if (r == 0) return {};  // then rest is 0 too.
  if (rest == 0) return {r};
  return {r, rest};
}

}  // namespace meshgauge
