// Summary statistics and outputs of an SDF run for the CLI.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "absl/status/status.h"
#include "client/cli/commands.h"
#include "lib/core/sdf_types.h"

namespace meshgauge::cli {

// The JSON summary of SPEC/README: vertices, faces, dimension, ok, no_hit,
// no_faces, degenerate_normal, sdf_min/median/max/mean (null when no value),
// integral, rays, seconds (`seconds`: the run until the values),
// rays_per_second, stage_seconds (read, checks, setup, rays), memory_bytes
// (mesh, derived, bvh, hit_table when local; peak_rss), plus method,
// volume and warnings: the mesh's, and a sentence per component whose missing
// values cover more than warn_fraction of the surface (MissingValueWarnings).
nlohmann::json SummaryJson(const Opened& opened, const SdfResult& result,
                           double seconds, double warn_fraction);

// The mesh's warnings, then a sentence per component whose missing values
// cover more than warn_fraction of the surface (MissingValueWarnings): the
// summary's `warnings`, and grad's and penalty's.
std::vector<std::string> PassWarnings(const Opened& opened,
                                      const SdfResult& result,
                                      double warn_fraction);

// Human-readable form of the same summary.
std::string SummaryText(const nlohmann::json& summary);

// Where result's samples are: the vertices, or the faces' centroids.
std::vector<Vec3> SamplePoints(const Mesh& mesh, const SdfResult& result);

// CSV: vertex,x,y,z,sdf,normalized,hits,kept,status (sdf and normalized
// empty unless status is OK; 17 significant digits), then ox,oy,oz with
// opposite points; face samples: face,x,y,z,... with x,y,z the centroid.
// A vertex-sample result per input vertex of a welded mesh (--weld: each
// input vertex gets its welded vertex's row), with the positions to show
// for them. Precondition: vertex samples.
struct InputSamples {
  Mesh points;  // positions only.
  SdfResult result;
};
InputSamples Unwelded(const Weld& weld, const Mesh& mesh,
                      const SdfResult& result);

absl::Status WriteSdfCsv(const std::string& path, const Mesh& mesh,
                         const SdfResult& result);

}  // namespace meshgauge::cli
