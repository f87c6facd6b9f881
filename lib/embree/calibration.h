// Calibration report of SPEC §8 (thesis §3.3.5): the SDF (CONE) against the
// physical thickness (NORMAL_RAY) per vertex.
#pragma once

#include "absl/status/statusor.h"
#include "lib/core/calibration_types.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge {

// Runs both passes on the evaluator's current positions.
// Errors: InvalidArgument (params), Cancelled; FailedPrecondition when no
// vertex has both values.
absl::StatusOr<CalibrationReport> Calibrate(const SdfEvaluator& evaluator,
                                            const CalibrationParams& params,
                                            const ComputeControl& control = {});

}  // namespace meshgauge
