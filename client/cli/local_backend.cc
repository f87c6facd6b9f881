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
  Local(std::unique_ptr<SdfEvaluator> ev, ProgressMode progress, int threads)
      : ev_(std::move(ev)), progress_(progress), threads_(threads) {}

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
        ev_->Compute(params, Threaded(bar.Control()),
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
    return ComputeJacobian(*ev_, hits_, Threaded(bar.Control()));
  }
  absl::StatusOr<std::vector<Vec3>> Vjp(
      const std::vector<double>& weights) override {
    ProgressBar bar("derivatives (g^T J)", progress_);
    return ComputeVjp(*ev_, hits_, weights, Threaded(bar.Control()));
  }
  absl::StatusOr<PenaltyResult> Penalty(const SdfResult& pass,
                                        const PenaltyParams& params,
                                        bool with_gradient) override {
    ProgressBar bar("penalty gradient", progress_);
    return ComputePenalty(*ev_, pass, params, with_gradient ? &hits_ : nullptr,
                          Threaded(bar.Control()));
  }
  absl::StatusOr<CalibrationReport> Calibrate(
      const CalibrationParams& params) override {
    return meshgauge::Calibrate(*ev_, params, Threaded({}));
  }
  absl::StatusOr<GradCheckReport> GradCheck(
      const SdfParams& params, const GradCheckOptions& options,
      const ComputeControl& control) override {
    return RunGradCheck(*ev_, params, options, Threaded(control));
  }

 private:
  // `control` with this backend's threads.
  ComputeControl Threaded(ComputeControl control) const {
    control.threads = threads_;
    return control;
  }

  std::unique_ptr<SdfEvaluator> ev_;
  const ProgressMode progress_;
  const int threads_;
  HitTable hits_;
};

}  // namespace

BackendFactory LocalBackend(ProgressMode progress, int threads) {
  return [progress,
          threads](Mesh mesh) -> absl::StatusOr<std::unique_ptr<Backend>> {
    auto ev = SdfEvaluator::Create(std::move(mesh),
                                   {.bvh_policy = BvhUpdatePolicy::kRebuild});
    if (!ev.ok()) return ev.status();
    return std::make_unique<Local>(std::move(*ev), progress, threads);
  };
}

}  // namespace meshgauge::cli
