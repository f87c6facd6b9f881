// libFuzzer target for one mesh reader (MESHGAUGE_FUZZ_FORMAT, e.g. ".ply"):
// any input must give a mesh or an error, never a crash, a sanitizer
// finding, a hang or an allocation the input cannot justify. A mesh that
// parses is also validated and diagnosed, as the CLI does.
#include <cstddef>
#include <cstdint>

#include "lib/core/components.h"
#include "lib/core/mesh.h"
#include "lib/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view contents(reinterpret_cast<const char*>(data), size);
  auto file = meshgauge::ParseMeshContents(contents, MESHGAUGE_FUZZ_FORMAT,
                                           "fuzz-input");
  if (!file.ok()) return 0;
  if (meshgauge::ValidateMesh(file->mesh).ok()) {
    meshgauge::DiagnoseMesh(file->mesh);
    meshgauge::ReorientComponents(file->mesh);
  }
  return 0;
}
