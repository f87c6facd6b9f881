#include "server/record_codec.h"

#include <bit>
#include <cstring>
#include <type_traits>

#include "absl/strings/str_cat.h"

namespace meshgauge::server {
namespace {

static_assert(sizeof(Vec3) == 3 * sizeof(double));
static_assert(std::endian::native == std::endian::little,
              "the record encoding is little-endian");

class Writer {
 public:
  template <typename T>
  void Put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void PutString(const std::string& s) {
    Put<uint32_t>(static_cast<uint32_t>(s.size()));
    out_ += s;
  }
  std::string Take() { return std::move(out_); }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(const std::string& in) : in_(in) {}
  template <typename T>
  bool Get(T* v) {
    if (in_.size() - pos_ < sizeof(T)) return false;
    std::memcpy(v, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  bool GetString(std::string* s) {
    uint32_t n = 0;
    if (!Get(&n) || in_.size() - pos_ < n) return false;
    s->assign(in_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  // Room for n items of `size` bytes (checked before allocating).
  bool Has(uint64_t n, size_t size) const {
    return n <= (in_.size() - pos_) / size;
  }
  bool AtEnd() const { return pos_ == in_.size(); }

 private:
  const std::string& in_;
  size_t pos_ = 0;
};

absl::Status Corrupt(const char* what) {
  return absl::DataLossError(
      absl::StrCat("the session store holds a corrupt ", what, " record"));
}

}  // namespace

std::string EncodeInfo(const wire::SessionInfo& info) {
  Writer w;
  w.Put<int32_t>(info.dimension);
  w.Put<int64_t>(info.num_vertices);
  w.Put<int64_t>(info.num_faces);
  w.Put<int64_t>(info.memory_bytes);
  w.Put<double>(info.signed_volume);
  w.Put<uint8_t>(info.closed);
  w.Put<uint32_t>(static_cast<uint32_t>(info.warnings.size()));
  for (const std::string& s : info.warnings) w.PutString(s);
  return w.Take();
}

absl::Status DecodeInfo(const std::string& bytes, wire::SessionInfo* info) {
  Reader r(bytes);
  int32_t dim = 0;
  uint8_t closed = 0;
  uint32_t warnings = 0;
  if (!r.Get(&dim) || !r.Get(&info->num_vertices) || !r.Get(&info->num_faces) ||
      !r.Get(&info->memory_bytes) || !r.Get(&info->signed_volume) ||
      !r.Get(&closed) || !r.Get(&warnings) ||
      !r.Has(warnings, sizeof(uint32_t)) || (dim != 2 && dim != 3)) {
    return Corrupt("info");
  }
  info->dimension = dim;
  info->closed = closed != 0;
  info->warnings.resize(warnings);
  for (std::string& s : info->warnings) {
    if (!r.GetString(&s)) return Corrupt("info");
  }
  return r.AtEnd() ? absl::OkStatus() : Corrupt("info");
}

std::string EncodeTopology(const Mesh& mesh) {
  Writer w;
  w.Put<int32_t>(mesh.dimension);
  w.Put<uint64_t>(mesh.faces.size());
  for (const Face& f : mesh.faces) {
    w.Put<int32_t>(f.size);
    for (int32_t v : f.v) w.Put<int32_t>(v);
  }
  w.Put<uint64_t>(mesh.face_regions.size());
  for (int32_t r : mesh.face_regions) w.Put<int32_t>(r);
  w.Put<uint64_t>(mesh.region_directions.size());
  for (const auto& [region, dir] : mesh.region_directions) {
    w.Put<int32_t>(region);
    w.Put<uint8_t>(dir == ConeDirection::kOutward);
  }
  return w.Take();
}

absl::Status DecodeTopology(const std::string& bytes, Mesh* mesh) {
  Reader r(bytes);
  int32_t dim = 0;
  uint64_t n = 0;
  if (!r.Get(&dim) || (dim != 2 && dim != 3) || !r.Get(&n) ||
      !r.Has(n, 5 * sizeof(int32_t))) {
    return Corrupt("mesh");
  }
  mesh->dimension = dim;
  mesh->faces.resize(n);
  for (Face& f : mesh->faces) {
    r.Get(&f.size);
    for (int32_t& v : f.v) r.Get(&v);
  }
  if (!r.Get(&n) || !r.Has(n, sizeof(int32_t))) return Corrupt("mesh");
  mesh->face_regions.resize(n);
  for (int32_t& region : mesh->face_regions) r.Get(&region);
  if (!r.Get(&n) || !r.Has(n, 5)) return Corrupt("mesh");
  for (uint64_t i = 0; i < n; ++i) {
    int32_t region = 0;
    uint8_t outward = 0;
    r.Get(&region);
    r.Get(&outward);
    mesh->region_directions[region] =
        outward ? ConeDirection::kOutward : ConeDirection::kInward;
  }
  return r.AtEnd() ? absl::OkStatus() : Corrupt("mesh");
}

std::string EncodePositions(const std::vector<Vec3>& positions) {
  return std::string(reinterpret_cast<const char*>(positions.data()),
                     positions.size() * sizeof(Vec3));
}

absl::StatusOr<std::vector<Vec3>> DecodePositions(const std::string& bytes,
                                                  int64_t expected_count) {
  if (bytes.size() != static_cast<uint64_t>(expected_count) * sizeof(Vec3)) {
    return Corrupt("positions");
  }
  std::vector<Vec3> out(expected_count);
  std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

}  // namespace meshgauge::server
