// A PLY file's header (format, elements and their properties), parsed and
// checked, for the body readers: the general one (ply_reader.cc) and the
// one for binary triangle meshes (ply_triangles.cc).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace meshgauge::io::ply {

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

// The type a header names ("uchar", "uint8", ...); false for none.
bool ParseType(absl::string_view name, Type* out);
// Bytes of one binary value.
size_t SizeOf(Type t);
bool IsInteger(Type t);

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

struct Header {
  Format format = Format::kAscii;
  std::vector<Element> elements;
  size_t body = 0;    // the body's first byte.
  int64_t lines = 0;  // the header's lines, end_header's included.
};

// The header: lines up to end_header. Errors: InvalidArgument naming the
// line of `path`.
absl::StatusOr<Header> ParseHeader(absl::string_view data,
                                   const std::string& path);

// Each element's declared count against the body's bytes that can hold
// them (`data_size`: the whole file's), before any allocation. Errors:
// InvalidArgument.
absl::Status CheckCounts(const Header& h, size_t data_size,
                         const std::string& path);

// "ply ascii", "ply binary_little_endian" or "ply binary_big_endian".
const char* FormatName(Format format);

}  // namespace meshgauge::io::ply
