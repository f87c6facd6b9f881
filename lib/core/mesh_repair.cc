#include "lib/core/mesh_repair.h"

#include <tbb/task_arena.h>

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "lib/core/thread_count.h"

namespace meshgauge {
namespace {

std::vector<std::string> RepairSentences(const RepairedMesh& r) {
  std::vector<std::string> out;
  if (r.weld.merged > 0) {
    out.push_back(absl::StrCat(
        r.weld.merged, " vertices welded into others (--weld, weld=): ",
        r.mesh.num_vertices(),
        " remain; values and gradients are given per input vertex"));
  }
  if (r.dropped_faces > 0) {
    out.push_back(
        absl::StrCat(r.dropped_faces,
                     " zero-area faces dropped (--drop-degenerate-faces, "
                     "drop_degenerate_faces=True)"));
  }
  const Reorientation& o = r.reorientation;
  if (o.faces_made_consistent > 0) {
    out.push_back(absl::StrCat(
        o.faces_made_consistent, " faces in ", o.components_made_consistent,
        " components reversed to agree with their neighbours (reorient)"));
  }
  if (o.non_orientable_components > 0) {
    out.push_back(absl::StrCat(
        o.non_orientable_components,
        " components cannot be oriented consistently (non-orientable, like a "
        "Moebius band)"));
  }
  if (o.components_turned_outward > 0) {
    out.push_back(
        absl::StrCat(o.components_turned_outward,
                     " inward-oriented closed components reversed (reorient)"));
  }
  return out;
}

}  // namespace

absl::StatusOr<RepairedMesh> RepairAndDiagnose(Mesh mesh,
                                               const RepairOptions& options) {
  RepairedMesh r;
  if (options.weld) {
    auto weld = WeldVertices(mesh, options.weld_tolerance);
    if (!weld.ok()) return weld.status();
    r.weld = std::move(*weld);
  }
  if (options.drop_degenerate_faces) {
    r.dropped_faces = DropDegenerateFaces(mesh);
  }
  tbb::task_arena arena(ThreadCount(options.threads));
  const absl::Status valid = arena.execute([&] { return ValidateMesh(mesh); });
  if (!valid.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        valid.message(),
        absl::StrContains(valid.message(), "zero area")
            ? " (--drop-degenerate-faces or drop_degenerate_faces=True "
              "removes them)"
            : ""));
  }
  arena.execute([&] {
    r.diagnostics = options.reorient
                        ? ReorientAndDiagnose(mesh, &r.reorientation)
                        : DiagnoseMesh(mesh);
  });
  r.signed_volume = SignedVolume(mesh);
  r.mesh = std::move(mesh);
  std::vector<std::string> warnings = RepairSentences(r);
  for (std::string& w : r.diagnostics.warnings) {
    warnings.push_back(std::move(w));
  }
  r.diagnostics.warnings = std::move(warnings);
  return r;
}

}  // namespace meshgauge
