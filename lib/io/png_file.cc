#include "lib/io/png_file.h"

#include <png.h>

#include <cstring>
#include <filesystem>

#include "absl/strings/str_cat.h"

namespace meshgauge {

absl::Status WritePng(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0) {
    return absl::InvalidArgumentError("cannot write an empty image");
  }
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  png.width = image.width;
  png.height = image.height;
  png.format = PNG_FORMAT_RGB;
  static_assert(sizeof(Rgb) == 3);
  if (!png_image_write_to_file(&png, path.c_str(), 0, image.pixels.data(), 0,
                               nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    return absl::InternalError(
        absl::StrCat("cannot write '", path, "': ", message));
  }
  return absl::OkStatus();
}

absl::StatusOr<Image> ReadPng(const std::string& path) {
  if (!std::filesystem::exists(path)) {
    return absl::NotFoundError(absl::StrCat("no file '", path, "'"));
  }
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path, "' is not a PNG: ", png.message));
  }
  if (png.width > 16384 || png.height > 16384) {
    png_image_free(&png);
    return absl::InvalidArgumentError(absl::StrCat(
        "'", path, "' is ", png.width, "x", png.height, " (max 16384)"));
  }
  png.format = PNG_FORMAT_RGB;
  Image image(png.width, png.height);
  png_color white{255, 255, 255};
  if (!png_image_finish_read(&png, &white, image.pixels.data(), 0, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read '", path, "': ", message));
  }
  return image;
}

}  // namespace meshgauge
