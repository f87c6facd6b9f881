#include "lib/io/ply_header.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "lib/io/scan.h"

namespace meshgauge::io::ply {

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

namespace {

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

}  // namespace

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

}  // namespace meshgauge::io::ply
