// Bounds-checked scanning of mesh file contents held in memory: tokens with
// line numbers for the text formats, little/big-endian scalars with byte
// offsets for the binary ones, and exact number parsing (a decimal is
// rounded once to the nearest double, std::from_chars).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace meshgauge::io {

// A UTF-8 byte-order mark, which some editors write at the start of a text
// file.
inline constexpr absl::string_view kUtf8Bom = "\xEF\xBB\xBF";

// Whitespace-separated tokens; `comment` starts a comment to the end of the
// line (0: none); with `continuation`, a backslash right before a line end
// joins the next line to this one (OBJ). Every call advances, so a scan is
// O(text size).
class TokenScanner {
 public:
  explicit TokenScanner(absl::string_view text, char comment = 0,
                        bool continuation = false)
      : text_(text), comment_(comment), continuation_(continuation) {}
  // The next token, or false at the end of the text.
  bool Next(absl::string_view* token);
  // The next token if it is on the current line (does not cross a newline).
  bool NextOnLine(absl::string_view* token);
  // Skips to the start of the next line.
  void SkipLine();
  int64_t line() const { return line_; }  // 1-based line of the last token.
  size_t offset() const { return pos_; }
  bool AtEnd();  // true when only whitespace and comments remain.

 private:
  void SkipSpace(bool cross_lines);
  // The length of a line continuation ("\\\n" or "\\\r\n") at `at`, or 0.
  size_t ContinuationAt(size_t at) const;
  absl::string_view text_;
  char comment_;
  bool continuation_;
  size_t pos_ = 0;
  int64_t line_ = 1;
};

// Parses the whole token as a finite double / an integer. Return false on
// any other content, on overflow (1e999) and on nan or inf.
bool ParseDouble(absl::string_view token, double* out);
bool ParseInt64(absl::string_view token, int64_t* out);

// Reads scalars from binary data; every read is checked against the end.
class ByteReader {
 public:
  ByteReader(absl::string_view data, size_t offset, bool big_endian)
      : data_(data), pos_(offset), big_endian_(big_endian) {}
  size_t offset() const { return pos_; }
  size_t remaining() const { return data_.size() - pos_; }
  // Copies `size` bytes (1, 2, 4 or 8) into *out in host order; false when
  // fewer remain.
  bool Read(void* out, size_t size);
  template <typename T>
  bool Get(T* out) {
    return Read(out, sizeof(T));
  }

 private:
  absl::string_view data_;
  size_t pos_;
  bool big_endian_;
};

// A text file's place "line N", made only when called: what
// MeshBuilder::AddFace takes as a face's place.
inline auto AtLine(int64_t line) {
  return [line] { return absl::StrCat("line ", line); };
}

// InvalidArgument "path: line N: message" / "path: byte N: message".
absl::Status LineError(const std::string& path, int64_t line,
                       absl::string_view message);
absl::Status ByteError(const std::string& path, size_t offset,
                       absl::string_view message);

// The count a header declares may be allocated only if the bytes left can
// hold that many elements of at least `min_bytes` each. Returns the error
// otherwise (naming what, the count and the bytes), before any allocation.
absl::Status CheckDeclaredCount(const std::string& path, absl::string_view what,
                                int64_t count, int64_t min_bytes,
                                size_t bytes_left);

// Token text for messages: at most 40 characters, control characters
// escaped.
std::string Quote(absl::string_view token);

// InvalidArgument when `text` has a CR but no LF: lines ended as on classic
// Mac OS, which a line-based format would read as one line (and name its
// first bad token). A copy with LF ends would double the bytes held.
absl::Status CheckLineEnds(const std::string& path, absl::string_view text);

}  // namespace meshgauge::io
