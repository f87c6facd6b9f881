// PLY, ASCII and binary (little and big endian): the header's elements and
// properties are honoured; `vertex` needs x, y, z (any numeric type;
// doubles are read exactly), `face` a list named vertex_indices or
// vertex_index (integer items), `tristrips` (triangle strips, as the
// Stanford scanning repository's files) the same list. Other elements and
// properties are parsed and skipped. The common binary triangle mesh is
// read by ReadTriangleBody (ply_triangles.cc) instead, into the same mesh.
#include <cmath>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/ply_body.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge::io {
namespace ply {
namespace {

// The triangles of a strip: index -1 starts a new strip; triangle i of a
// strip is (s_i, s_i+1, s_i+2), the odd ones reversed so that all keep the
// strip's orientation. The zero-area triangles a strip uses to turn (a
// repeated index) are not faces and are skipped.
class StripDecoder {
 public:
  void Restart() { seen_ = 0; }
  // The triangle that index `v` completes, if any.
  bool Add(int64_t v, int64_t triangle[3]) {
    if (v == -1) {
      Restart();
      return false;
    }
    const bool complete = seen_ >= 2 && a_ != b_ && b_ != v && a_ != v;
    if (complete) {
      const bool odd = (seen_ - 2) % 2 == 1;
      triangle[0] = odd ? b_ : a_;
      triangle[1] = odd ? a_ : b_;
      triangle[2] = v;
    }
    a_ = b_;
    b_ = v;
    ++seen_;
    return complete;
  }

 private:
  int64_t seen_ = 0, a_ = -1, b_ = -1;
};

template <typename T>
bool ReadAs(ByteReader& in, double* out) {
  T v;
  if (!in.Get(&v)) return false;
  *out = static_cast<double>(v);
  return true;
}

// Reads one binary scalar of type t as a double (exact for every type).
bool ReadBinary(ByteReader& in, Type t, double* out) {
  switch (t) {
    case Type::kInt8:
      return ReadAs<int8_t>(in, out);
    case Type::kUint8:
      return ReadAs<uint8_t>(in, out);
    case Type::kInt16:
      return ReadAs<int16_t>(in, out);
    case Type::kUint16:
      return ReadAs<uint16_t>(in, out);
    case Type::kInt32:
      return ReadAs<int32_t>(in, out);
    case Type::kUint32:
      return ReadAs<uint32_t>(in, out);
    case Type::kFloat32:
      return ReadAs<float>(in, out);
    case Type::kFloat64:
      return ReadAs<double>(in, out);
  }
  return false;
}

// Reads scalars from either the ASCII body or the binary one, naming the
// place of the last value read in messages.
class ValueSource {
 public:
  ValueSource(absl::string_view data, size_t body, Format format)
      : format_(format),
        tokens_(data.substr(body)),
        bytes_(data, body, format == Format::kBig) {}
  // False at the end of the data or on a token that is not a number.
  bool Next(Type t, double* out) {
    if (format_ != Format::kAscii) {
      return ReadBinary(bytes_, t, out) && std::isfinite(*out);
    }
    absl::string_view tok;
    if (!tokens_.Next(&tok)) return false;
    if (IsInteger(t)) {
      int64_t i;
      if (!ParseInt64(tok, &i)) return false;
      *out = static_cast<double>(i);
      return true;
    }
    return ParseDouble(tok, out);
  }
  std::string Where() const {
    return format_ == Format::kAscii
               ? absl::StrCat("line ", tokens_.line() + header_lines_)
               : absl::StrCat("byte ", bytes_.offset());
  }
  bool AtEnd() {
    return format_ == Format::kAscii ? tokens_.AtEnd()
                                     : bytes_.remaining() == 0;
  }
  size_t remaining() const {
    return format_ == Format::kAscii ? 0 : bytes_.remaining();
  }
  void set_header_lines(int64_t n) { header_lines_ = n - 1; }

 private:
  Format format_;
  TokenScanner tokens_;
  ByteReader bytes_;
  int64_t header_lines_ = 0;
};

// What an element is to the mesh: the properties its vertices or faces are
// read from (-1: none).
struct ElementRole {
  bool is_vertex = false;
  bool is_strips = false;  // tristrips: faces as triangle strips.
  bool is_face = false;    // face or tristrips.
  int xyz[3] = {-1, -1, -1};
  int indices = -1;
};

// The role of `e`, checked, with the builder's room reserved for it.
// `have_vertices`: whether element vertex came before.
absl::StatusOr<ElementRole> StartElement(const Element& e,
                                         const std::string& path,
                                         bool have_vertices,
                                         MeshBuilder& builder) {
  ElementRole role;
  role.is_vertex = e.name == "vertex";
  role.is_strips = e.name == "tristrips";
  role.is_face = e.name == "face" || role.is_strips;
  for (size_t i = 0; i < e.properties.size(); ++i) {
    const Property& p = e.properties[i];
    if (role.is_vertex && !p.list) {
      for (int c = 0; c < 3; ++c) {
        if (p.name == std::string(1, static_cast<char>('x' + c))) {
          role.xyz[c] = i;
        }
      }
    }
    if (role.is_face && p.list &&
        (p.name == "vertex_indices" || p.name == "vertex_index")) {
      if (!IsInteger(p.type)) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": ", e.name, " property ", p.name,
                         " has a non-integer type"));
      }
      role.indices = static_cast<int>(i);
    }
  }
  if (role.is_vertex) {
    if (role.xyz[0] < 0 || role.xyz[1] < 0 || role.xyz[2] < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": element vertex lacks property x, y or z"));
    }
    if (absl::Status s = builder.ReservePositions(e.count); !s.ok()) return s;
  }
  if (role.is_face && role.indices < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": element ", e.name, " lacks a list property vertex_indices"));
  }
  if (role.is_face && !have_vertices) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": element ", e.name, " comes before element vertex"));
  }
  if (role.is_face && !role.is_strips) {
    if (absl::Status s = builder.ReserveFaces(e.count, 3); !s.ok()) return s;
  }
  return role;
}

// Reads the instances of one element from the body, adding its vertices
// and faces to the builder.
class ElementReader {
 public:
  ElementReader(const Element& e, const ElementRole& role, Format format,
                const std::string& path, ValueSource* in, MeshBuilder* builder)
      : e_(e),
        role_(role),
        format_(format),
        path_(path),
        in_(*in),
        builder_(*builder),
        row_(e.properties.size(), 0.0) {}

  absl::Status ReadAll() {
    for (int64_t k = 0; k < e_.count; ++k) {
      if (absl::Status s = ReadInstance(k); !s.ok()) return s;
    }
    return absl::OkStatus();
  }

 private:
  // Instance k: its scalars into row_, its face's corners into corners_
  // (a strip's triangles straight to the builder).
  absl::Status ReadInstance(int64_t k) {
    corners_.clear();
    strip_.Restart();
    for (size_t i = 0; i < e_.properties.size(); ++i) {
      const Property& p = e_.properties[i];
      if (p.list) {
        if (absl::Status s = ReadList(k, i); !s.ok()) return s;
      } else if (!in_.Next(p.type, &row_[i])) {
        return absl::InvalidArgumentError(absl::StrCat(
            path_, ": ", in_.Where(), ": ", e_.name, " ", k, " of ", e_.count,
            ": property ", p.name, " is missing or not a finite number"));
      }
    }
    if (role_.is_vertex) {
      return builder_.AddVertex(
          {row_[role_.xyz[0]], row_[role_.xyz[1]], row_[role_.xyz[2]]});
    }
    if (role_.is_face && !role_.is_strips) {
      return builder_.AddFace(corners_, 0, [this] { return in_.Where(); });
    }
    return absl::OkStatus();
  }

  // List property i of instance k; its items are kept only when it holds
  // the face's vertex indices.
  absl::Status ReadList(int64_t k, size_t i) {
    const Property& p = e_.properties[i];
    double n;
    if (!in_.Next(p.count_type, &n) || n < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(path_, ": ", in_.Where(), ": ", e_.name, " ", k,
                       ": list count of ", p.name, " is missing or negative"));
    }
    if (format_ != Format::kAscii &&
        n * SizeOf(p.type) > static_cast<double>(in_.remaining())) {
      return absl::InvalidArgumentError(absl::StrCat(
          path_, ": ", in_.Where(), ": ", e_.name, " ", k, ": list of ", n,
          " items runs past the end of the file"));
    }
    for (int64_t j = 0; j < static_cast<int64_t>(n); ++j) {
      double item;
      if (!in_.Next(p.type, &item)) {
        return absl::InvalidArgumentError(
            absl::StrCat(path_, ": ", in_.Where(), ": ", e_.name, " ", k,
                         ": list ", p.name, " has fewer than ", n, " items"));
      }
      if (static_cast<int>(i) != role_.indices) continue;
      int64_t triangle[3];
      if (!role_.is_strips) {
        if (j <= kMaxCornersPerRecord) {
          corners_.push_back(static_cast<int64_t>(item));
        }
      } else if (strip_.Add(static_cast<int64_t>(item), triangle)) {
        if (absl::Status s =
                builder_.AddFace(triangle, 0, [this] { return in_.Where(); });
            !s.ok()) {
          return s;
        }
      }
    }
    return absl::OkStatus();
  }

  const Element& e_;
  const ElementRole& role_;
  const Format format_;
  const std::string& path_;
  ValueSource& in_;
  MeshBuilder& builder_;
  std::vector<double> row_;  // per property: the instance's scalar.
  std::vector<int64_t> corners_;
  StripDecoder strip_;
};

absl::Status NoFacesError(const std::vector<Element>& elements,
                          const std::string& path) {
  std::string names;
  for (const Element& e : elements) {
    absl::StrAppend(&names, names.empty() ? "" : ", ", e.name, " ", e.count);
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": no faces (elements: ", names,
                   "; faces are read from 'face' and 'tristrips')"));
}

}  // namespace

absl::StatusOr<MeshFile> ReadBody(absl::string_view data, const Header& h,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  MeshBuilder builder(path, 3, &limits);
  ValueSource in(data, h.body, h.format);
  in.set_header_lines(h.lines + 1);
  bool have_vertices = false;
  for (const Element& e : h.elements) {
    auto role = StartElement(e, path, have_vertices, builder);
    if (!role.ok()) return role.status();
    have_vertices |= role->is_vertex;
    ElementReader reader(e, *role, h.format, path, &in, &builder);
    if (absl::Status s = reader.ReadAll(); !s.ok()) return s;
  }
  if (!in.AtEnd()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", in.Where(),
                     ": unexpected data after the declared elements"));
  }
  if (builder.num_faces() == 0) return NoFacesError(h.elements, path);
  return builder.Finish(FormatName(h.format));
}

}  // namespace ply

absl::StatusOr<MeshFile> ParsePly(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  auto header = ply::ParseHeader(data, path);
  if (!header.ok()) return header.status();
  if (absl::Status s = ply::CheckCounts(*header, data.size(), path); !s.ok()) {
    return s;
  }
  if (auto read = ply::ReadTriangleBody(data, *header, path, limits)) {
    return *std::move(read);
  }
  return ply::ReadBody(data, *header, path, limits);
}

}  // namespace meshgauge::io
