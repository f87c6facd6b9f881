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
        bytes_(data, body, format == Format::kBig),
        body_(body) {}
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
  size_t body_;
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

}  // namespace

absl::StatusOr<MeshFile> ParsePly(absl::string_view data,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  // Header: lines up to end_header.
  size_t pos = 0;
  int64_t line_no = 0;
  auto next_line = [&](absl::string_view* line) {
    if (pos >= data.size()) return false;
    size_t end = data.find('\n', pos);
    if (end == absl::string_view::npos) end = data.size();
    *line = data.substr(pos, end - pos);
    if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
    pos = end + 1;
    ++line_no;
    return true;
  };
  absl::string_view line;
  if (!next_line(&line) || line != "ply") {
    return LineError(path, 1, "not a PLY file (first line is not 'ply')");
  }
  Format format = Format::kAscii;
  bool have_format = false, ended = false;
  std::vector<Element> elements;
  while (next_line(&line)) {
    TokenScanner words(line);
    absl::string_view w;
    if (!words.Next(&w)) continue;
    if (w == "end_header") {
      ended = true;
      break;
    }
    if (w == "comment" || w == "obj_info") continue;
    if (w == "format") {
      absl::string_view f, version;
      if (!words.Next(&f) || !words.Next(&version) || version != "1.0") {
        return LineError(path, line_no, "expected 'format TYPE 1.0'");
      }
      if (f == "ascii") {
        format = Format::kAscii;
      } else if (f == "binary_little_endian") {
        format = Format::kLittle;
      } else if (f == "binary_big_endian") {
        format = Format::kBig;
      } else {
        return LineError(path, line_no,
                         absl::StrCat("unknown format ", Quote(f)));
      }
      have_format = true;
    } else if (w == "element") {
      absl::string_view name, count;
      Element e;
      if (!words.Next(&name) || !words.Next(&count) ||
          !ParseInt64(count, &e.count) || e.count < 0) {
        return LineError(path, line_no, "expected 'element NAME COUNT >= 0'");
      }
      e.name = std::string(name);
      elements.push_back(std::move(e));
    } else if (w == "property") {
      if (elements.empty()) {
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
        if (!words.Next(&ct) || !words.Next(&it) ||
            !ParseType(ct, &p.count_type) || !IsInteger(p.count_type) ||
            !ParseType(it, &p.type)) {
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
      elements.back().properties.push_back(std::move(p));
    } else if (data.find("end_header") == absl::string_view::npos) {
      return LineError(path, line_no,
                       absl::StrCat("the header has no end_header line (the "
                                    "file is cut short, or ",
                                    Quote(w), " is not a header keyword)"));
    } else {
      return LineError(path, line_no,
                       absl::StrCat("unknown header keyword ", Quote(w)));
    }
  }
  if (!ended) {
    return LineError(path, line_no, "the header has no end_header line");
  }
  if (!have_format) return LineError(path, line_no, "no format line");
  const size_t body = std::min(pos, data.size());
  // Counts against the bytes that can hold them, before any allocation.
  size_t left = data.size() - body;
  for (const Element& e : elements) {
    const int64_t min = MinBytes(e, format);
    if (absl::Status s = CheckDeclaredCount(path, e.name, e.count, min, left);
        !s.ok())
      return s;
    left -= e.count * min;
  }
  MeshBuilder builder(path, 3, &limits);
  ValueSource in(data, body, format);
  in.set_header_lines(line_no + 1);
  const std::string fmt_name =
      format == Format::kAscii
          ? "ply ascii"
          : (format == Format::kLittle ? "ply binary_little_endian"
                                       : "ply binary_big_endian");
  bool have_vertices = false;
  std::vector<int64_t> corners;
  std::vector<double> row;
  StripDecoder strip;
  for (const Element& e : elements) {
    const bool is_vertex = e.name == "vertex";
    const bool is_strips = e.name == "tristrips";
    const bool is_face = e.name == "face" || is_strips;
    int xyz[3] = {-1, -1, -1};
    int indices = -1;
    for (size_t i = 0; i < e.properties.size(); ++i) {
      const Property& p = e.properties[i];
      if (is_vertex && !p.list) {
        for (int c = 0; c < 3; ++c) {
          if (p.name == std::string(1, static_cast<char>('x' + c))) xyz[c] = i;
        }
      }
      if (is_face && p.list &&
          (p.name == "vertex_indices" || p.name == "vertex_index")) {
        if (!IsInteger(p.type)) {
          return absl::InvalidArgumentError(
              absl::StrCat(path, ": ", e.name, " property ", p.name,
                           " has a non-integer type"));
        }
        indices = static_cast<int>(i);
      }
    }
    if (is_vertex) {
      if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": element vertex lacks property x, y or z"));
      }
      have_vertices = true;
      if (absl::Status s = builder.ReservePositions(e.count); !s.ok()) {
        return s;
      }
    }
    if (is_face && indices < 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          path, ": element ", e.name, " lacks a list property vertex_indices"));
    }
    if (is_face && !have_vertices) {
      return absl::InvalidArgumentError(absl::StrCat(
          path, ": element ", e.name, " comes before element vertex"));
    }
    if (is_face && !is_strips) {
      if (absl::Status s = builder.ReserveFaces(e.count, 3); !s.ok()) return s;
    }
    row.assign(e.properties.size(), 0.0);
    for (int64_t k = 0; k < e.count; ++k) {
      corners.clear();
      strip.Restart();
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const Property& p = e.properties[i];
        if (!p.list) {
          if (!in.Next(p.type, &row[i])) {
            return absl::InvalidArgumentError(absl::StrCat(
                path, ": ", in.Where(), ": ", e.name, " ", k, " of ", e.count,
                ": property ", p.name, " is missing or not a finite number"));
          }
          continue;
        }
        double n;
        if (!in.Next(p.count_type, &n) || n < 0) {
          return absl::InvalidArgumentError(absl::StrCat(
              path, ": ", in.Where(), ": ", e.name, " ", k, ": list count of ",
              p.name, " is missing or negative"));
        }
        if (format != Format::kAscii &&
            n * SizeOf(p.type) > static_cast<double>(in.remaining())) {
          return absl::InvalidArgumentError(absl::StrCat(
              path, ": ", in.Where(), ": ", e.name, " ", k, ": list of ", n,
              " items runs past the end of the file"));
        }
        for (int64_t j = 0; j < static_cast<int64_t>(n); ++j) {
          double item;
          if (!in.Next(p.type, &item)) {
            return absl::InvalidArgumentError(absl::StrCat(
                path, ": ", in.Where(), ": ", e.name, " ", k, ": list ", p.name,
                " has fewer than ", n, " items"));
          }
          if (static_cast<int>(i) != indices) continue;
          int64_t triangle[3];
          if (!is_strips) {
            if (j <= kMaxCornersPerRecord) {
              corners.push_back(static_cast<int64_t>(item));
            }
          } else if (strip.Add(static_cast<int64_t>(item), triangle)) {
            if (absl::Status s = builder.AddFace(triangle, 0, in.Where());
                !s.ok()) {
              return s;
            }
          }
        }
      }
      if (is_vertex) {
        if (absl::Status s =
                builder.AddVertex({row[xyz[0]], row[xyz[1]], row[xyz[2]]});
            !s.ok()) {
          return s;
        }
      } else if (is_face && !is_strips) {
        if (absl::Status s = builder.AddFace(corners, 0, in.Where()); !s.ok())
          return s;
      }
    }
  }
  if (!in.AtEnd()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", in.Where(),
                     ": unexpected data after the declared elements"));
  }
  if (builder.num_faces() == 0) {
    std::string names;
    for (const Element& e : elements) {
      absl::StrAppend(&names, names.empty() ? "" : ", ", e.name, " ", e.count);
    }
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": no faces (elements: ", names,
                     "; faces are read from 'face' and 'tristrips')"));
  }
  return builder.Finish(fmt_name);
}

}  // namespace meshgauge::io
