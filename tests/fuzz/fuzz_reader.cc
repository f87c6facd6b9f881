// libFuzzer target for one mesh reader (MESHGAUGE_FUZZ_FORMAT, e.g. ".ply"):
// any input must give a mesh or an error, never a crash, a sanitizer
// finding, a hang or an allocation the input cannot justify. A mesh that
// parses is also repaired, validated and diagnosed, as the CLI and the
// server's file uploads do.
#include <cstddef>
#include <cstdint>
#include <utility>

#include "lib/core/mesh_repair.h"
#include "lib/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view contents(reinterpret_cast<const char*>(data), size);
  auto file = meshgauge::ParseMeshContents(contents, MESHGAUGE_FUZZ_FORMAT,
                                           "fuzz-input");
  if (!file.ok()) return 0;
  (void)meshgauge::ReaderWarnings(*file);
  (void)meshgauge::RepairAndDiagnose(
      std::move(file->mesh), {.drop_degenerate_faces = true, .reorient = true});
  return 0;
}
