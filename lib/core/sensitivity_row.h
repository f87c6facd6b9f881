// A sample's row of the Jacobian as its terms arrive (the sensitivities'
// scratch, lib/core/sensitivity.cc; apart so that tests can drive it).
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "lib/core/row_term.h"
#include "lib/core/topology.h"
#include "lib/core/vec3.h"

namespace meshgauge {

// A sample's row of the Jacobian, summed per vertex as its terms arrive
// (entries in the order of each vertex's first term, each the sum of its
// terms in arrival order). On coarse meshes a sample's rays hit few
// primitives, many times each; on fine ones nearly every ray hits its own
// (docs/sensitivities.md). One per thread slot of the computation's arena,
// kept across samples. A vertex's entry is found through a small
// open-addressing index sized to the row (at least 256 entries, twice the
// row's), not a slot per vertex of the mesh, which held 4 bytes a vertex
// per thread (VjpMemoryTest).
class SampleRow {
 public:
  void Clear() {
    terms_.clear();
    // Entries of earlier rows hold older stamps: nothing to erase.
    if (++stamp_ == 0) {
      std::fill(index_.begin(), index_.end(), 0);
      for (Memo& m : memo_) m.stamp = 0;
      stamp_ = 1;
    }
  }
  void Add(int32_t vertex, const Vec3& d) { (void)AddAt(vertex, d); }
  // As Add(prim.v[j], corner(j)) for each corner j of primitive `id` in
  // turn: a primitive met before in this row finds its entries without a
  // search (on coarse meshes most of a sample's rays hit a primitive an
  // earlier one hit).
  template <typename Corner>
  void AddCorners(int32_t id, const Primitive& prim, Corner corner) {
    Memo& m = memo_[static_cast<uint32_t>(id) & (kMemo - 1)];
    if (m.stamp == stamp_ && m.id == id) {
      for (int j = 0; j < 3 && prim.v[j] >= 0; ++j) {
        terms_[m.at[j]].d += corner(j);
      }
      return;
    }
    m.stamp = stamp_;
    m.id = id;
    for (int j = 0; j < 3 && prim.v[j] >= 0; ++j) {
      m.at[j] = AddAt(prim.v[j], corner(j));
    }
  }
  // Swaps the terms into `out` and clears the row, which keeps out's
  // storage for the next sample.
  void TakeTerms(std::vector<RowTerm>& out) {
    terms_.swap(out);
    Clear();
  }

 private:
  // Add, returning the entry's place in terms_ (fixed until Clear).
  uint32_t AddAt(int32_t vertex, const Vec3& d) {
    if (2 * (terms_.size() + 1) > index_.size()) Grow();
    for (size_t h = Hash(vertex);; h = (h + 1) & mask_) {
      const uint64_t entry = index_[h];
      if (entry >> 32 != stamp_) {
        const auto at = static_cast<uint32_t>(terms_.size());
        index_[h] = Entry(at);
        terms_.push_back({vertex, Vec3() + d});  // -0 sums to +0, as before.
        return at;
      }
      const auto at = static_cast<uint32_t>(entry);
      RowTerm& t = terms_[at];
      if (t.vertex == vertex) {
        t.d += d;
        return at;
      }
    }
  }
  uint64_t Entry(size_t term) const {
    return uint64_t{stamp_} << 32 | static_cast<uint32_t>(term);
  }
  size_t Hash(int32_t vertex) const {
    return (static_cast<uint32_t>(vertex) * 0x9E3779B1u) >> shift_;
  }
  // Doubles the index (at least 256 entries) and re-enters every term.
  void Grow() {
    const size_t size = std::max<size_t>(256, 2 * index_.size());
    index_.assign(size, 0);
    mask_ = size - 1;
    shift_ = 32 - std::countr_zero(size);
    for (size_t i = 0; i < terms_.size(); ++i) {
      size_t h = Hash(terms_[i].vertex);
      while (index_[h] >> 32 == stamp_) h = (h + 1) & mask_;
      index_[h] = Entry(i);
    }
  }

  // Where the entries of a primitive's corners are, by its index modulo
  // kMemo (AddCorners).
  static constexpr size_t kMemo = 64;
  struct Memo {
    uint32_t stamp = 0;
    int32_t id = -1;
    uint32_t at[3];
  };
  std::array<Memo, kMemo> memo_{};
  std::vector<RowTerm> terms_;
  // Open addressing by vertex: the row's stamp (high 32 bits) and the
  // term's position in terms_; an entry with another stamp is free.
  std::vector<uint64_t> index_;
  uint32_t stamp_ = 1;
  size_t mask_ = 0;
  int shift_ = 32;
};

}  // namespace meshgauge
