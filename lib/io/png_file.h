// PNG files of an Image (8-bit RGB) through libpng's simplified API.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "lib/core/image.h"

namespace meshgauge {

// Errors: InvalidArgument for an empty image; Internal when the file cannot
// be written (libpng's message).
absl::Status WritePng(const std::string& path, const Image& image);

// Reads any PNG as 8-bit RGB (alpha composited on white). Errors: NotFound
// for a missing file, InvalidArgument for a file that is not a PNG or is
// larger than 16384 x 16384.
absl::StatusOr<Image> ReadPng(const std::string& path);

}  // namespace meshgauge
