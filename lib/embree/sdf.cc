#include "lib/embree/sdf.h"

namespace meshgauge {

absl::StatusOr<SdfResult> ComputeSdf(const Mesh& mesh, const SdfParams& params,
                                     const ComputeControl& control) {
  if (absl::Status s = ValidateParams(params); !s.ok()) return s;
  auto evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild});
  if (!evaluator.ok()) return evaluator.status();
  return (*evaluator)->Compute(params, control);
}

}  // namespace meshgauge
