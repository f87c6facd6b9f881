// STL, binary (80-byte header, facet count, 50 bytes per facet: the size
// must match exactly) or ASCII (solid / facet normal / outer loop / 3 x
// vertex / endloop / endfacet / endsolid). Facet corners are welded by
// exactly equal coordinates, in order of first appearance.
#include <cstring>
#include <unordered_map>

#include "absl/hash/hash.h"
#include "absl/strings/str_cat.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge::io {
namespace {

struct Key {
  double x, y, z;
  bool operator==(const Key& o) const {
    return std::memcmp(this, &o, sizeof(Key)) == 0;
  }
  template <typename H>
  friend H AbslHashValue(H h, const Key& k) {
    return H::combine(std::move(h), k.x, k.y, k.z);
  }
};

class Welder {
 public:
  explicit Welder(MeshBuilder* b) : builder_(b) {}
  absl::StatusOr<int64_t> Index(const Vec3& p) {
    // +0.0 and -0.0 are one position.
    const Key key{p.x + 0.0, p.y + 0.0, p.z + 0.0};
    if (map_.size() >= reported_) {
      // The map's nodes and buckets count as the reader's memory: reported
      // ahead, for twice as many positions.
      reported_ = std::max<size_t>(2 * map_.size(), 1024);
      if (absl::Status s = builder_->SetExtraBytes(
              static_cast<int64_t>(reported_) * kBytesPerPosition);
          !s.ok()) {
        return s;
      }
    }
    auto [it, inserted] = map_.try_emplace(key, builder_->num_vertices());
    if (inserted) {
      if (absl::Status s = builder_->AddVertex(p); !s.ok()) return s;
    }
    ++corners_;
    return it->second;
  }
  int64_t welded() const { return corners_ - builder_->num_vertices(); }

 private:
  // A node (key, index, link, cached hash, allocator overhead) and about
  // a bucket pointer per position.
  static constexpr int64_t kBytesPerPosition = 72;
  MeshBuilder* builder_;
  std::unordered_map<Key, int64_t, absl::Hash<Key>> map_;
  size_t reported_ = 0;
  int64_t corners_ = 0;
};

absl::StatusOr<MeshFile> ParseBinaryStl(absl::string_view data,
                                        const std::string& path, uint32_t count,
                                        const ReadLimits& limits) {
  MeshBuilder builder(path, 3, &limits);
  Welder welder(&builder);
  ByteReader in(data, 84, /*big_endian=*/false);
  for (uint32_t f = 0; f < count; ++f) {
    float v[12];
    for (float& x : v) in.Get(&x);  // sizes were checked: 50 bytes/facet.
    uint16_t attribute;
    in.Get(&attribute);
    int64_t corners[3];
    for (int c = 0; c < 3; ++c) {
      const Vec3 p(v[3 + 3 * c], v[4 + 3 * c], v[5 + 3 * c]);
      if (!IsFinite(p)) {
        return ByteError(
            path, 84 + 50 * static_cast<size_t>(f) + 12 + 12 * c,
            absl::StrCat("facet ", f, ": corner ", c, " is not finite"));
      }
      auto index = welder.Index(p);
      if (!index.ok()) return index.status();
      corners[c] = *index;
    }
    if (absl::Status s = builder.AddFace(
            corners, 0,
            [f] {
              return absl::StrCat("byte ", 84 + 50 * static_cast<size_t>(f));
            });
        !s.ok())
      return s;
  }
  const int64_t welded = welder.welded();
  auto file = builder.Finish("stl binary");
  if (file.ok()) file->welded_corners = welded;
  return file;
}

absl::StatusOr<MeshFile> ParseAsciiStl(absl::string_view text,
                                       const std::string& path,
                                       const ReadLimits& limits) {
  MeshBuilder builder(path, 3, &limits);
  Welder welder(&builder);
  TokenScanner scan(text);
  absl::string_view tok;
  auto expect = [&](absl::string_view word) -> absl::Status {
    if (scan.Next(&tok) && tok == word) return absl::OkStatus();
    return LineError(
        path, scan.line(),
        absl::StrCat("expected '", word, "', got ",
                     tok.empty() ? "the end of the file" : Quote(tok)));
  };
  auto number = [&](double* out) -> absl::Status {
    if (scan.NextOnLine(&tok) && ParseDouble(tok, out)) return absl::OkStatus();
    return LineError(path, scan.line(), "expected a finite number");
  };
  bool any_solid = false;
  while (scan.Next(&tok)) {
    if (tok != "solid") {
      return LineError(path, scan.line(),
                       absl::StrCat("expected 'solid', got ", Quote(tok)));
    }
    any_solid = true;
    scan.SkipLine();  // the solid's name.
    while (true) {
      tok = {};
      if (!scan.Next(&tok)) {
        return LineError(path, scan.line(), "missing 'endsolid'");
      }
      if (tok == "endsolid") {
        scan.SkipLine();
        break;
      }
      if (tok != "facet") {
        return LineError(
            path, scan.line(),
            absl::StrCat("expected 'facet' or 'endsolid', got ", Quote(tok)));
      }
      const int64_t line = scan.line();
      double ignored;
      if (absl::Status s = expect("normal"); !s.ok()) return s;
      for (int c = 0; c < 3; ++c) {
        if (absl::Status s = number(&ignored); !s.ok()) return s;
      }
      if (absl::Status s = expect("outer"); !s.ok()) return s;
      if (absl::Status s = expect("loop"); !s.ok()) return s;
      int64_t corners[3];
      for (int c = 0; c < 3; ++c) {
        if (absl::Status s = expect("vertex"); !s.ok()) return s;
        double xyz[3];
        for (double& x : xyz) {
          if (absl::Status s = number(&x); !s.ok()) return s;
        }
        auto index = welder.Index({xyz[0], xyz[1], xyz[2]});
        if (!index.ok()) return index.status();
        corners[c] = *index;
      }
      if (absl::Status s = expect("endloop"); !s.ok()) return s;
      if (absl::Status s = expect("endfacet"); !s.ok()) return s;
      if (absl::Status s = builder.AddFace(corners, 0, AtLine(line)); !s.ok())
        return s;
    }
  }
  if (!any_solid || builder.num_faces() == 0) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": no facets"));
  }
  const int64_t welded = welder.welded();
  auto file = builder.Finish("stl ascii");
  if (file.ok()) file->welded_corners = welded;
  return file;
}

}  // namespace

absl::StatusOr<MeshFile> ParseStl(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  if (data.size() >= 84) {
    uint32_t count;
    std::memcpy(&count, data.data() + 80, 4);
    if (data.size() == 84 + 50 * static_cast<uint64_t>(count)) {
      if (count == 0) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": no facets"));
      }
      return ParseBinaryStl(data, path, count, limits);
    }
  }
  uint32_t count = 0;
  if (data.size() >= 84) std::memcpy(&count, data.data() + 80, 4);
  const std::string not_binary =
      data.size() >= 84
          ? absl::StrCat("the header declares ", count, " facets, ",
                         84 + 50 * static_cast<uint64_t>(count),
                         " bytes, but the file has ", data.size())
          : std::string("shorter than the 84-byte binary header");
  if (data.substr(0, 5) == "solid") {
    auto ascii = ParseAsciiStl(data, path, limits);
    // A NUL byte is no ASCII STL's: a binary one (its header may start with
    // "solid") whose size does not match its count, truncated or padded.
    if (ascii.ok() || data.find('\0') == absl::string_view::npos) return ascii;
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": a binary STL whose size does not match its facet count (",
        not_binary,
        "; its header starts with 'solid', as some exporters "
        "write, but it is not ASCII STL)"));
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path,
                   ": not an STL file: not ASCII (no 'solid'), and not "
                   "binary (",
                   not_binary, ")"));
}

}  // namespace meshgauge::io
