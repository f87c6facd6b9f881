// Small text files a program is pointed at (certificates, token files).
#pragma once

#include <string>

#include "absl/status/statusor.h"

namespace meshgauge {

// The whole file. Errors: NotFound "cannot read the WHAT 'PATH'".
absl::StatusOr<std::string> ReadTextFile(const std::string& path,
                                         const std::string& what);

}  // namespace meshgauge
