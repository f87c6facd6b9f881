// Linear-time grouping of items by a small integer key (a vertex index), for
// the mesh checks' sorts (issue 27: no comparison sort over all faces).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace meshgauge {

// The items that for_each(emit) emits as emit(bucket, item), bucket in
// [0, num_buckets), grouped by ascending bucket and, within a bucket,
// sorted stably by `less` (items of equal order stay in emission order).
// for_each is called twice and must emit the same sequence both times.
// Linear in the items plus num_buckets when buckets stay small (each is
// insertion-sorted up to 32 items, merge-sorted beyond).
template <typename T, typename ForEach, typename Less>
std::vector<T> BucketSorted(int64_t num_buckets, ForEach for_each, Less less) {
  std::vector<int64_t> start(num_buckets + 1, 0);
  for_each([&](int64_t bucket, const T&) { ++start[bucket + 1]; });
  for (int64_t b = 0; b < num_buckets; ++b) start[b + 1] += start[b];
  std::vector<T> items(start[num_buckets]);
  {
    std::vector<int64_t> next(start.begin(), start.end() - 1);
    for_each(
        [&](int64_t bucket, const T& item) { items[next[bucket]++] = item; });
  }
  for (int64_t b = 0; b < num_buckets; ++b) {
    T* const first = items.data() + start[b];
    T* const last = items.data() + start[b + 1];
    if (last - first < 2) continue;  // (items.data() may be null.)
    if (last - first > 32) {
      std::stable_sort(first, last, less);
      continue;
    }
    for (T* i = first + 1; i < last; ++i) {  // insertion sort
      const T item = *i;
      T* j = i;
      for (; j > first && less(item, *(j - 1)); --j) *j = *(j - 1);
      *j = item;
    }
  }
  return items;
}

}  // namespace meshgauge
