#include "absl/strings/str_cat.h"
#include "client/cli/backend.h"
#include "client/cli/progress_bar.h"
#include "lib/core/face_sample.h"
#include "lib/embree/calibration.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/ray_hit.h"
#include "lib/embree/sdf_evaluator.h"

namespace meshgauge::cli {
namespace {

class Local : public Backend {
 public:
  Local(std::unique_ptr<SdfEvaluator> ev, ProgressMode progress)
      : ev_(std::move(ev)), progress_(progress) {}

  const Mesh& mesh() const override { return ev_->mesh(); }

  absl::StatusOr<SdfResult> Sdf(const SdfParams& params,
                                Derivatives derivatives) override {
    const int64_t rays = ResolveParams(params, ev_->mesh().dimension).rays;
    ProgressBar bar(
        absl::StrCat("tracing ", NumSamples(ev_->mesh(), params.samples) * rays,
                     " rays"),
        progress_);
    hits_ = HitTable();
    auto result =
        ev_->Compute(params, bar.Control(),
                     derivatives == Derivatives::kNone ? nullptr : &hits_);
    bar.Finish();
    return result;
  }
  std::optional<MemoryBytes> Memory() const override {
    return MemoryBytes{.mesh = ev_->MeshBytes(),
                       .derived = ev_->DerivedBytes(),
                       .bvh = RayTracerBytes(),
                       .hit_table = hits_.Bytes()};
  }
  absl::StatusOr<SparseJacobian> Jacobian() override {
    ProgressBar bar("jacobian rows", progress_);
    return ComputeJacobian(*ev_, hits_, bar.Control());
  }
  absl::StatusOr<std::vector<Vec3>> Vjp(
      const std::vector<double>& weights) override {
    ProgressBar bar("derivatives (g^T J)", progress_);
    return ComputeVjp(*ev_, hits_, weights, bar.Control());
  }
  absl::StatusOr<PenaltyResult> Penalty(const SdfResult& pass,
                                        const PenaltyParams& params,
                                        bool with_gradient) override {
    ProgressBar bar("penalty gradient", progress_);
    return ComputePenalty(*ev_, pass, params, with_gradient ? &hits_ : nullptr,
                          bar.Control());
  }
  absl::StatusOr<CalibrationReport> Calibrate(
      const CalibrationParams& params) override {
    return meshgauge::Calibrate(*ev_, params);
  }
  absl::StatusOr<GradCheckReport> GradCheck(
      const SdfParams& params, const GradCheckOptions& options,
      const ComputeControl& control) override {
    return RunGradCheck(*ev_, params, options, control);
  }

 private:
  std::unique_ptr<SdfEvaluator> ev_;
  const ProgressMode progress_;
  HitTable hits_;
};

}  // namespace

BackendFactory LocalBackend(ProgressMode progress) {
  return [progress](Mesh mesh) -> absl::StatusOr<std::unique_ptr<Backend>> {
    auto ev = SdfEvaluator::Create(std::move(mesh));
    if (!ev.ok()) return ev.status();
    return std::make_unique<Local>(std::move(*ev), progress);
  };
}

}  // namespace meshgauge::cli
