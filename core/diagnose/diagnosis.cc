// RunDiagnosis: the method's stages in order (internal/stages.h lists them and their
// files), and the fit runner they share.
#include <chrono>
#include <cstdio>

#include "core/common/parallel.h"
#include "core/diagnose/internal/stages.h"

namespace wormdrag::diagnose {

Status DiagnoseOptions::Validate() const {
  if (points.empty()) return Status::InvalidArgument("at least one evaluation point is needed");
  for (int p : points)
    if (p < 0 || p > kNumLinks)
      return Status::InvalidArgument("evaluation point " + std::to_string(p) + " is not 0 … 13");
  if (!(t_max > 0)) return Status::InvalidArgument("t_max must be positive");
  if (!(epsilon > 0)) return Status::InvalidArgument("eps must be positive");
  if (substeps < 1 || substeps > 64) return Status::InvalidArgument("substeps must be 1 … 64");
  if (blocks != 0 && (blocks < kMinBlocks || blocks > kMaxBlocks)) {
    char b[96];
    std::snprintf(b, sizeof b, "blocks must be %d … %d (or 0: one per %g s)", kMinBlocks, kMaxBlocks, kBlockSeconds);
    return Status::InvalidArgument(b);
  }
  if (null_replicates < 2 || null_replicates > 200) return Status::InvalidArgument("null replicates must be 2 … 200");
  if (threads < 0) return Status::InvalidArgument("threads must be >= 0");
  if (grg_iterations < 1 || base_iterations < 1) return Status::InvalidArgument("GRG iterations must be >= 1");
  if (!(fit_hz >= 0) || !std::isfinite(fit_hz)) return Status::InvalidArgument("fit_hz must be >= 0 (0 = every frame)");
  if (!(lowpass_hz >= 0) || !std::isfinite(lowpass_hz))
    return Status::InvalidArgument("lowpass_hz must be >= 0 (0 = no low-pass)");
  WORMDRAG_RETURN_IF_ERROR(spline.Validate());
  if (!(cv_ridge >= 0) || !std::isfinite(cv_ridge)) return Status::InvalidArgument("cv_ridge must be >= 0");
  if (!(false_alarm_rate > 0) || !(false_alarm_rate < 1))
    return Status::InvalidArgument("false_alarm_rate must lie between 0 and 1 (e.g. 0.05)");
  if (refine_top < 0) return Status::InvalidArgument("refine_top must be >= 0");
  if (simex_draws < 0 || simex_draws > 50) return Status::InvalidArgument("simex_draws must be 0 … 50");
  if (simex_top < 0) return Status::InvalidArgument("simex_top must be >= 0");
  if (!(simex_weight >= 0) || !std::isfinite(simex_weight)) return Status::InvalidArgument("simex_weight must be >= 0");
  if (!(simex_min_keep >= 0) || !(simex_min_keep <= 1)) return Status::InvalidArgument("simex_min_keep must be 0 … 1");
  if (!(clear_margin >= 1) || !std::isfinite(clear_margin)) return Status::InvalidArgument("clear_margin must be >= 1");
  for (const auto& e : effects) {
    auto x = ParseEffectName(e);
    if (!x.ok()) return x.status();
    if (!InfoOf(*x).in_catalogue)
      return Status::InvalidArgument("effect " + e + " is not in the catalogue (it is never fitted)");
  }
  return Status::Ok();
}

namespace internal {

DiagnosisRun::DiagnosisRun(const std::array<Kinematics, 2>& recordings, const std::array<std::string, 2>& names,
                           const DiagnoseOptions& options)
    : recordings(recordings), o(options), threads(options.threads > 0 ? options.threads : DefaultThreads()) {
  out.names = names;
}

void DiagnosisRun::Progress(const std::string& stage, double fraction) const {
  if (o.progress) o.progress(stage, fraction);
}

void DiagnosisRun::StartFits(const std::string& stage, int total) {
  fits_stage_ = stage;
  fits_done_ = 0;
  fits_total_ = total;
  Progress(stage, 0);
}

Result<std::vector<FitOutcome>> DiagnosisRun::RunFits(const std::vector<FitTask>& tasks) {
  return o.run_fits ? o.run_fits(tasks) : RunLocally(tasks);
}

Result<std::vector<FitOutcome>> DiagnosisRun::RunLocally(const std::vector<FitTask>& tasks) {
  std::vector<Result<FitOutcome>> res(tasks.size(), Status::Cancelled("diagnosis cancelled"));
  // Many fits: one thread each. A lone fit: its stencil points in parallel.
  const int inner = tasks.size() < static_cast<size_t>(threads) ? threads : 1;
  ParallelFor(static_cast<int64_t>(tasks.size()), threads / inner, [&](int, int64_t i) {
    if (Cancelled()) return;
    FitSpec fs = tasks[i].spec;
    fs.threads = inner;
    res[i] = FitModel(*replicate_data[tasks[i].replicate], fs);
    if (fits_total_ > 0) Progress(fits_stage_, double(++fits_done_) / fits_total_);
  });
  std::vector<FitOutcome> fits;
  for (auto& r : res) {
    if (!r.ok()) return r.status();
    fits.push_back(std::move(*r));
  }
  return fits;
}

}  // namespace internal

Result<Diagnosis> RunDiagnosis(const std::array<Kinematics, 2>& recordings, const std::array<std::string, 2>& names,
                               const DiagnoseOptions& o) {
  using namespace internal;
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  const auto t_start = std::chrono::steady_clock::now();
  DiagnosisRun run(recordings, names, o);
  // Prepare the recordings, fit the base model, and see where its residual lies.
  WORMDRAG_RETURN_IF_ERROR(PrepareRecordings(&run));
  WORMDRAG_RETURN_IF_ERROR(FitBase(&run));
  MeasureWhere(&run);
  // Which effect: every model cross-validated on the data and on noise-only replicates,
  // the closest effect refitted on its own, the leading ones checked on noisy copies.
  WORMDRAG_RETURN_IF_ERROR(MakeNullReplicates(&run));
  WORMDRAG_RETURN_IF_ERROR(CrossValidate(&run));
  WORMDRAG_RETURN_IF_ERROR(RefitClosest(&run));
  WORMDRAG_RETURN_IF_ERROR(CheckSimex(&run));
  // The noise floors, then the verdict and how far.
  AddNullToWhere(&run);
  CollectScores(&run);
  Decide(o, &run.out);
  run.out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  run.Progress("done", 1);
  return std::move(run.out);
}

}  // namespace wormdrag::diagnose
