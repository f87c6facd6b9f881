#include "client/cli/backend.h"
#include "client/cli/progress_bar.h"
#include "lib/embree/calibration.h"
#include "lib/embree/ray_hit.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge::cli {
namespace {

class Local : public Backend {
 public:
  explicit Local(std::unique_ptr<SdfEvaluator> ev) : ev_(std::move(ev)) {}

  absl::StatusOr<SdfResult> Sdf(const SdfParams& params,
                                Derivatives derivatives) override {
    ProgressBar bar("tracing");
    ComputeControl control;
    control.progress = [&bar](int64_t d, int64_t t) { bar.Update(d, t); };
    hits_ = HitTable();
    auto result = ev_->Compute(
        params, control, derivatives == Derivatives::kNone ? nullptr : &hits_);
    bar.Finish();
    if (result.ok()) result_ = *result;
    return result;
  }
  std::optional<MemoryBytes> Memory() const override {
    return MemoryBytes{.mesh = ev_->MeshBytes(),
                       .derived = ev_->DerivedBytes(),
                       .bvh = RayTracerBytes(),
                       .hit_table = hits_.Bytes()};
  }
  absl::StatusOr<SparseJacobian> Jacobian() override {
    return ComputeJacobian(*ev_, hits_);
  }
  absl::StatusOr<std::vector<Vec3>> Vjp(
      const std::vector<double>& weights) override {
    return ComputeVjp(*ev_, hits_, weights);
  }
  absl::StatusOr<PenaltyResult> Penalty(const PenaltyParams& params,
                                        bool with_gradient) override {
    return ComputePenalty(*ev_, result_, params,
                          with_gradient ? &hits_ : nullptr);
  }
  absl::StatusOr<CalibrationReport> Calibrate(
      const CalibrationParams& params) override {
    return meshgauge::Calibrate(*ev_, params);
  }

 private:
  std::unique_ptr<SdfEvaluator> ev_;
  HitTable hits_;
  SdfResult result_;
};

}  // namespace

BackendFactory LocalBackend() {
  return [](const Mesh& mesh) -> absl::StatusOr<std::unique_ptr<Backend>> {
    auto ev = SdfEvaluator::Create(mesh);
    if (!ev.ok()) return ev.status();
    return std::make_unique<Local>(std::move(*ev));
  };
}

}  // namespace meshgauge::cli
