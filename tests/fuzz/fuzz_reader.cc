// libFuzzer target for one mesh reader (MESHGAUGE_FUZZ_FORMAT, e.g. ".ply"):
// any input must give a mesh or an error, never a crash, a sanitizer
// finding, a hang or an allocation the input cannot justify. A mesh that
// parses is also repaired, validated and diagnosed, as the CLI and the
// server's file uploads do. For PLY, whatever the binary triangle reader
// (ReadTriangleBody) takes must be exactly what the general reader makes
// of it.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "lib/core/mesh_repair.h"
#include "lib/io/mesh_io.h"
#include "lib/io/ply_body.h"

namespace {

// Aborts when ReadTriangleBody takes `contents` and reads it otherwise than
// ReadBody.
void CheckTriangleReader(absl::string_view contents) {
  namespace ply = meshgauge::io::ply;
  auto header = ply::ParseHeader(contents, "fuzz-input");
  if (!header.ok() ||
      !ply::CheckCounts(*header, contents.size(), "fuzz-input").ok()) {
    return;
  }
  auto fast = ply::ReadTriangleBody(contents, *header, "fuzz-input", {});
  if (!fast) return;
  auto general = ply::ReadBody(contents, *header, "fuzz-input", {});
  if (!fast->ok() || !general.ok()) std::abort();
  const meshgauge::Mesh &a = (*fast)->mesh, &b = general->mesh;
  if (a.positions.size() != b.positions.size() ||
      std::memcmp(a.positions.data(), b.positions.data(),
                  a.positions.size() * sizeof(meshgauge::Vec3)) != 0 ||
      a.faces.size() != b.faces.size() ||
      (*fast)->file_faces != general->file_faces) {
    std::abort();
  }
  for (size_t f = 0; f < a.faces.size(); ++f) {
    if (a.faces[f].v != b.faces[f].v || a.faces[f].size != b.faces[f].size) {
      std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view contents(reinterpret_cast<const char*>(data), size);
  if (std::string_view(MESHGAUGE_FUZZ_FORMAT) == ".ply") {
    CheckTriangleReader(contents);
  }
  auto file = meshgauge::ParseMeshContents(contents, MESHGAUGE_FUZZ_FORMAT,
                                           "fuzz-input");
  if (!file.ok()) return 0;
  (void)meshgauge::ReaderWarnings(*file);
  (void)meshgauge::RepairAndDiagnose(
      std::move(file->mesh), {.drop_degenerate_faces = true, .reorient = true});
  return 0;
}
