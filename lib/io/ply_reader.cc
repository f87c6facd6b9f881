// PLY, ASCII and binary (little and big endian): the header's elements and
// properties are honoured; `vertex` needs x, y, z (any numeric type;
// doubles are read exactly), `face` a list named vertex_indices or
// vertex_index (integer items), `tristrips` (triangle strips, as the
// Stanford scanning repository's files) the same list. Other elements and
// properties are parsed and skipped.
#include <cmath>
#include <cstring>
#include <vector>

#include "absl/strings/str_cat.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge::io {
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

enum class Type {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64
};

bool ParseType(absl::string_view name, Type* out) {
  static const struct {
    const char* a;
    const char* b;
    Type t;
  } kTypes[] = {{"char", "int8", Type::kInt8},
                {"uchar", "uint8", Type::kUint8},
                {"short", "int16", Type::kInt16},
                {"ushort", "uint16", Type::kUint16},
                {"int", "int32", Type::kInt32},
                {"uint", "uint32", Type::kUint32},
                {"float", "float32", Type::kFloat32},
                {"double", "float64", Type::kFloat64}};
  for (const auto& t : kTypes) {
    if (name == t.a || name == t.b) {
      *out = t.t;
      return true;
    }
  }
  return false;
}

size_t SizeOf(Type t) {
  switch (t) {
    case Type::kInt8:
    case Type::kUint8:
      return 1;
    case Type::kInt16:
    case Type::kUint16:
      return 2;
    case Type::kInt32:
    case Type::kUint32:
    case Type::kFloat32:
      return 4;
    case Type::kFloat64:
      return 8;
  }
  return 1;
}

bool IsInteger(Type t) { return t != Type::kFloat32 && t != Type::kFloat64; }

struct Property {
  std::string name;
  Type type = Type::kFloat32;
  bool list = false;
  Type count_type = Type::kUint8;
};

struct Element {
  std::string name;
  int64_t count = 0;
  std::vector<Property> properties;
};

enum class Format { kAscii, kLittle, kBig };

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

// The least bytes one instance of `e` takes (lists empty).
int64_t MinBytes(const Element& e, Format format) {
  int64_t bytes = 0;
  for (const Property& p : e.properties) {
    bytes += format == Format::kAscii
                 ? 2
                 : static_cast<int64_t>(SizeOf(p.list ? p.count_type : p.type));
  }
  return std::max<int64_t>(bytes, 1);
}

// The header's lines, one at a time (CR LF or LF ended), counted from 1.
class HeaderLines {
 public:
  explicit HeaderLines(absl::string_view data) : data_(data) {}
  bool Next(absl::string_view* line) {
    if (pos_ >= data_.size()) return false;
    size_t end = data_.find('\n', pos_);
    if (end == absl::string_view::npos) end = data_.size();
    *line = data_.substr(pos_, end - pos_);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    pos_ = end + 1;
    ++line_no_;
    return true;
  }
  // The byte after the last line read (may be past the end).
  size_t pos() const { return pos_; }
  int64_t line_no() const { return line_no_; }

 private:
  absl::string_view data_;
  size_t pos_ = 0;
  int64_t line_no_ = 0;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  size_t body = 0;    // the body's first byte.
  int64_t lines = 0;  // the header's lines, end_header's included.
};

// `words` after "format" on line `line_no`.
absl::Status ParseFormat(TokenScanner& words, const std::string& path,
                         int64_t line_no, Format* format) {
  absl::string_view f, version;
  if (!words.Next(&f) || !words.Next(&version) || version != "1.0") {
    return LineError(path, line_no, "expected 'format TYPE 1.0'");
  }
  if (f == "ascii") {
    *format = Format::kAscii;
  } else if (f == "binary_little_endian") {
    *format = Format::kLittle;
  } else if (f == "binary_big_endian") {
    *format = Format::kBig;
  } else {
    return LineError(path, line_no, absl::StrCat("unknown format ", Quote(f)));
  }
  return absl::OkStatus();
}

// `words` after "element" on line `line_no`.
absl::Status ParseElement(TokenScanner& words, const std::string& path,
                          int64_t line_no, std::vector<Element>* elements) {
  absl::string_view name, count;
  Element e;
  if (!words.Next(&name) || !words.Next(&count) ||
      !ParseInt64(count, &e.count) || e.count < 0) {
    return LineError(path, line_no, "expected 'element NAME COUNT >= 0'");
  }
  e.name = std::string(name);
  elements->push_back(std::move(e));
  return absl::OkStatus();
}

// `words` after "property" on line `line_no`: a property of the last
// element.
absl::Status ParseProperty(TokenScanner& words, const std::string& path,
                           int64_t line_no, std::vector<Element>* elements) {
  if (elements->empty()) {
    return LineError(path, line_no, "property before any element");
  }
  Property p;
  absl::string_view t, name;
  if (!words.Next(&t)) {
    return LineError(path, line_no, "expected a property type");
  }
  if (t == "list") {
    absl::string_view ct, it;
    p.list = true;
    if (!words.Next(&ct) || !words.Next(&it) || !ParseType(ct, &p.count_type) ||
        !IsInteger(p.count_type) || !ParseType(it, &p.type)) {
      return LineError(path, line_no,
                       "expected 'property list COUNT_TYPE ITEM_TYPE NAME' "
                       "with an integer count type");
    }
  } else if (!ParseType(t, &p.type)) {
    return LineError(path, line_no,
                     absl::StrCat("unknown property type ", Quote(t)));
  }
  if (!words.Next(&name)) {
    return LineError(path, line_no, "expected a property name");
  }
  p.name = std::string(name);
  elements->back().properties.push_back(std::move(p));
  return absl::OkStatus();
}

// The header: lines up to end_header.
absl::StatusOr<Header> ParseHeader(absl::string_view data,
                                   const std::string& path) {
  HeaderLines lines(data);
  absl::string_view line;
  if (!lines.Next(&line) || line != "ply") {
    return LineError(path, 1, "not a PLY file (first line is not 'ply')");
  }
  Header h;
  bool have_format = false, ended = false;
  while (lines.Next(&line)) {
    TokenScanner words(line);
    absl::string_view w;
    if (!words.Next(&w)) continue;
    if (w == "end_header") {
      ended = true;
      break;
    }
    if (w == "comment" || w == "obj_info") continue;
    const int64_t line_no = lines.line_no();
    absl::Status s;
    if (w == "format") {
      s = ParseFormat(words, path, line_no, &h.format);
      have_format = true;
    } else if (w == "element") {
      s = ParseElement(words, path, line_no, &h.elements);
    } else if (w == "property") {
      s = ParseProperty(words, path, line_no, &h.elements);
    } else if (data.find("end_header") == absl::string_view::npos) {
      s = LineError(path, line_no,
                    absl::StrCat("the header has no end_header line (the "
                                 "file is cut short, or ",
                                 Quote(w), " is not a header keyword)"));
    } else {
      s = LineError(path, line_no,
                    absl::StrCat("unknown header keyword ", Quote(w)));
    }
    if (!s.ok()) return s;
  }
  if (!ended) {
    return LineError(path, lines.line_no(),
                     "the header has no end_header line");
  }
  if (!have_format) return LineError(path, lines.line_no(), "no format line");
  h.body = std::min(lines.pos(), data.size());
  h.lines = lines.line_no();
  return h;
}

// Each element's declared count against the body's bytes that can hold
// them, before any allocation.
absl::Status CheckCounts(const Header& h, size_t data_size,
                         const std::string& path) {
  size_t left = data_size - h.body;
  for (const Element& e : h.elements) {
    const int64_t min = MinBytes(e, h.format);
    if (absl::Status s = CheckDeclaredCount(path, e.name, e.count, min, left);
        !s.ok())
      return s;
    left -= e.count * min;
  }
  return absl::OkStatus();
}

const char* FormatName(Format format) {
  switch (format) {
    case Format::kAscii:
      return "ply ascii";
    case Format::kLittle:
      return "ply binary_little_endian";
    case Format::kBig:
      return "ply binary_big_endian";
  }
  return "ply";
}

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

absl::StatusOr<MeshFile> ParsePly(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  auto header = ParseHeader(data, path);
  if (!header.ok()) return header.status();
  if (absl::Status s = CheckCounts(*header, data.size(), path); !s.ok()) {
    return s;
  }
  MeshBuilder builder(path, 3, &limits);
  ValueSource in(data, header->body, header->format);
  in.set_header_lines(header->lines + 1);
  bool have_vertices = false;
  for (const Element& e : header->elements) {
    auto role = StartElement(e, path, have_vertices, builder);
    if (!role.ok()) return role.status();
    have_vertices |= role->is_vertex;
    ElementReader reader(e, *role, header->format, path, &in, &builder);
    if (absl::Status s = reader.ReadAll(); !s.ok()) return s;
  }
  if (!in.AtEnd()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", in.Where(),
                     ": unexpected data after the declared elements"));
  }
  if (builder.num_faces() == 0) return NoFacesError(header->elements, path);
  return builder.Finish(FormatName(header->format));
}

}  // namespace meshgauge::io
