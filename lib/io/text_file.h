// Small text files a program is pointed at (certificates, token files).
#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace meshgauge {

// Largest file ReadTextFile reads: 1 MiB.
inline constexpr int64_t kMaxTextFileBytes = int64_t{1} << 20;

// The whole file, at most kMaxTextFileBytes (so /dev/zero or a misnamed
// mesh is refused, not read into memory). Errors: NotFound "cannot read the
// WHAT 'PATH'", InvalidArgument when the file is larger.
absl::StatusOr<std::string> ReadTextFile(const std::string& path,
                                         const std::string& what);

}  // namespace meshgauge
