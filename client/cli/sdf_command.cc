#include <iostream>

#include "absl/strings/str_cat.h"
#include "client/cli/backend.h"
#include "client/cli/commands.h"
#include "client/cli/summary.h"
#include "lib/core/missing_values.h"
#include "lib/core/stopwatch.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {

absl::StatusOr<Opened> Open(const MeshInput& in, const BackendFactory& make,
                            bool print_warnings) {
  auto params = ToSdfParams(in.sdf);
  if (!params.ok()) return params.status();
  auto loaded = LoadMesh(in.mesh, in.mesh_flags, in.sdf.threads);
  if (!loaded.ok()) return loaded.status();
  if (print_warnings) PrintWarnings(loaded->warnings);
  const Stopwatch setup;
  auto backend = make(std::move(loaded->mesh));
  if (!backend.ok()) return backend.status();
  return Opened{std::move(*loaded), std::move(*backend), *params,
                setup.Seconds()};
}

void PrintWarnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) {
    std::cerr << "meshgauge: warning: " << w << "\n";
  }
}

absl::Status RunSdf(const MeshInput& in, const BackendFactory& make) {
  const Stopwatch watch;
  auto opened = Open(in, make, /*print_warnings=*/false);  // in the summary.
  if (!opened.ok()) return opened.status();
  if (!in.out.opposite_ply.empty()) opened->params.opposite_points = true;
  auto result = opened->backend->Sdf(opened->params, Derivatives::kNone);
  if (!result.ok()) return result.status();
  const double seconds = watch.Seconds();
  const Mesh& mesh = opened->mesh();
  if (const std::string& csv = in.out.csv; !csv.empty()) {
    // A row per input vertex (--weld keeps the file's indexing).
    const bool welded = !opened->loaded.weld.welded_vertex.empty() &&
                        opened->params.samples == SampleSet::kVertices;
    const absl::Status s =
        welded ? [&] {
          const InputSamples rows = Unwelded(opened->loaded.weld, mesh, *result);
          return WriteSdfCsv(csv, rows.points, rows.result);
        }()
               : WriteSdfCsv(csv, mesh, *result);
    if (!s.ok()) return s;
  }
  if (const std::string& ply = in.out.ply; !ply.empty()) {
    const QualityOn on = result->resolved.params.samples == SampleSet::kFaces
                             ? QualityOn::kFaces
                             : QualityOn::kVertices;
    if (absl::Status s = WriteQualityPly(ply, mesh, result->values, {}, on);
        !s.ok()) {
      return s;
    }
  }
  if (const std::string& ply = in.out.opposite_ply; !ply.empty()) {
    if (absl::Status s = WriteSegmentsPly(ply, SamplePoints(mesh, *result),
                                          result->opposite, result->values);
        !s.ok()) {
      return s;
    }
  }
  const nlohmann::json summary =
      SummaryJson(*opened, *result, seconds, in.out.warn_missing_fraction);
  if (in.out.json) {
    std::cout << summary.dump() << "\n";
  } else {
    std::cout << SummaryText(summary);
  }
  // Nothing measured is an error, as grad, penalty and report make it:
  // written and summarised first, so that the warnings say where.
  if (!result->values.empty() &&
      result->CountStatus(VertexStatus::kOk) == 0) {
    return absl::FailedPreconditionError(absl::StrCat(
        "no ", result->resolved.params.samples == SampleSet::kFaces ? "face"
                                                                    : "vertex",
        " has a value: ", LikelyMissingCause(mesh, result->Causes())));
  }
  return absl::OkStatus();
}

}  // namespace meshgauge::cli
