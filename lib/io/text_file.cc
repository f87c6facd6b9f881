#include "lib/io/text_file.h"

#include <fstream>

#include "absl/strings/str_cat.h"

namespace meshgauge {

absl::StatusOr<std::string> ReadTextFile(const std::string& path,
                                         const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::NotFoundError(
        absl::StrCat("cannot read the ", what, " '", path, "'"));
  }
  std::string text(kMaxTextFileBytes + 1, '\0');
  in.read(text.data(), std::ssize(text));
  if (in.bad()) {
    return absl::NotFoundError(
        absl::StrCat("cannot read the ", what, " '", path, "'"));
  }
  if (in.gcount() > kMaxTextFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("the ", what, " '", path, "' is larger than ",
                     kMaxTextFileBytes, " bytes: not a ", what));
  }
  text.resize(in.gcount());
  return text;
}

}  // namespace meshgauge
