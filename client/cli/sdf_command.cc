#include <chrono>
#include <iostream>

#include "absl/strings/str_cat.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/cli/progress_bar.h"
#include "client/cli/summary.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {

absl::Status RunSdf(const MeshInput& in) {
  auto params = ToSdfParams(in.sdf);
  if (!params.ok()) return params.status();
  const auto start = std::chrono::steady_clock::now();
  auto loaded = LoadMesh(in.mesh, in.mesh_flags);
  if (!loaded.ok()) return loaded.status();
  ProgressBar bar("tracing");
  ComputeControl control;
  control.progress = [&bar](int64_t done, int64_t total) {
    bar.Update(done, total);
  };
  auto result = ComputeSdf(loaded->mesh, *params, control);
  bar.Finish();
  if (!result.ok()) return result.status();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  if (const std::string& csv = in.out.csv; !csv.empty()) {
    if (absl::Status s = WriteSdfCsv(csv, loaded->mesh, *result); !s.ok()) {
      return s;
    }
  }
  if (const std::string& ply = in.out.ply; !ply.empty()) {
    if (absl::Status s = WriteQualityPly(ply, loaded->mesh, result->values);
        !s.ok()) {
      return s;
    }
  }
  const nlohmann::json summary = SummaryJson(*loaded, *result, seconds);
  if (in.out.json) {
    std::cout << summary.dump() << "\n";
  } else {
    std::cout << SummaryText(summary);
  }
  return absl::OkStatus();
}

}  // namespace meshgauge::cli
