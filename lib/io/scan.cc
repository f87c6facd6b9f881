#include "lib/io/scan.h"

#include <charconv>
#include <cmath>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"

namespace meshgauge::io {
namespace {

bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' ||
         c == '\v';
}

}  // namespace

size_t TokenScanner::ContinuationAt(size_t at) const {
  if (!continuation_ || at >= text_.size() || text_[at] != '\\') return 0;
  if (at + 1 < text_.size() && text_[at + 1] == '\n') return 2;
  if (at + 2 < text_.size() && text_[at + 1] == '\r' && text_[at + 2] == '\n') {
    return 3;
  }
  return 0;
}

void TokenScanner::SkipSpace(bool cross_lines) {
  while (pos_ < text_.size()) {
    const char c = text_[pos_];
    if (const size_t n = ContinuationAt(pos_); n > 0) {
      pos_ += n;
      ++line_;
    } else if (c == '\n') {
      if (!cross_lines) return;
      ++line_;
      ++pos_;
    } else if (IsSpace(c)) {
      ++pos_;
    } else if (comment_ != 0 && c == comment_) {
      while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    } else {
      return;
    }
  }
}

bool TokenScanner::Next(absl::string_view* token) {
  SkipSpace(true);
  return NextOnLine(token);
}

bool TokenScanner::NextOnLine(absl::string_view* token) {
  SkipSpace(false);
  if (pos_ >= text_.size() || text_[pos_] == '\n') return false;
  const size_t start = pos_;
  while (pos_ < text_.size() && !IsSpace(text_[pos_]) &&
         !(comment_ != 0 && text_[pos_] == comment_) &&
         ContinuationAt(pos_) == 0) {
    ++pos_;
  }
  *token = text_.substr(start, pos_ - start);
  return true;
}

void TokenScanner::SkipLine() {
  while (pos_ < text_.size() && text_[pos_] != '\n') {
    if (const size_t n = ContinuationAt(pos_); n > 0) {
      pos_ += n;
      ++line_;
    } else {
      ++pos_;
    }
  }
  if (pos_ < text_.size()) {
    ++pos_;
    ++line_;
  }
}

bool TokenScanner::AtEnd() {
  SkipSpace(true);
  return pos_ >= text_.size();
}

bool ParseDouble(absl::string_view token, double* out) {
  const char* begin = token.data();
  const char* end = begin + token.size();
  if (begin != end && *begin == '+') ++begin;  // from_chars rejects '+'.
  if (begin == end || *begin == '+' || (*begin == '-' && begin + 1 == end)) {
    return false;
  }
  const auto [ptr, ec] = std::from_chars(begin, end, *out);
  return ec == std::errc() && ptr == end && std::isfinite(*out);
}

bool ParseInt64(absl::string_view token, int64_t* out) {
  const char* begin = token.data();
  const char* end = begin + token.size();
  if (begin != end && *begin == '+') ++begin;
  if (begin == end || *begin == '+') return false;
  const auto [ptr, ec] = std::from_chars(begin, end, *out);
  return ec == std::errc() && ptr == end;
}

bool ByteReader::Read(void* out, size_t size) {
  if (remaining() < size) return false;
  unsigned char* dst = static_cast<unsigned char*>(out);
  std::memcpy(dst, data_.data() + pos_, size);
  if (big_endian_) {
    for (size_t i = 0; i < size / 2; ++i) std::swap(dst[i], dst[size - 1 - i]);
  }
  pos_ += size;
  return true;
}

absl::Status LineError(const std::string& path, int64_t line,
                       absl::string_view message) {
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": line ", line, ": ", message));
}

absl::Status ByteError(const std::string& path, size_t offset,
                       absl::string_view message) {
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": byte ", offset, ": ", message));
}

absl::Status CheckDeclaredCount(const std::string& path, absl::string_view what,
                                int64_t count, int64_t min_bytes,
                                size_t bytes_left) {
  if (count < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": negative ", what, " count ", count));
  }
  if (count > static_cast<int64_t>(bytes_left) / min_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": declares ", count, " ", what, " but only ", bytes_left,
        " bytes follow (each needs at least ", min_bytes, ")"));
  }
  if (count > INT32_MAX) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": ", count, " ", what, " exceed the limit of 2^31 - 1"));
  }
  return absl::OkStatus();
}

std::string Quote(absl::string_view token) {
  std::string s = absl::CHexEscape(token.substr(0, 40));
  if (token.size() > 40) s += "...";
  return absl::StrCat("'", s, "'");
}

absl::Status CheckLineEnds(const std::string& path, absl::string_view text) {
  if (text.find('\n') != text.npos || text.find('\r') == text.npos) {
    return absl::OkStatus();
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path,
                   ": its lines end in CR alone (classic Mac OS); convert "
                   "them to LF or CR LF"));
}

}  // namespace meshgauge::io
