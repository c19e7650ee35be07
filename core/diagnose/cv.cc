// Cross-validation: every model's two fold fits on the data and on the noise-only
// replicates (one batch), the leading effect's own refit, and the scores Decide needs.
#include <algorithm>
#include <deque>
#include <map>

#include "core/diagnose/internal/stages.h"

namespace wormdrag::diagnose::internal {

ModelCv AssembleCv(const EffectData& d, const std::array<const FitOutcome*, 2>& folds, double eps) {
  ModelCv cv;
  const int B = d.blocks;
  cv.held_out.sum.assign(2 * B, 0);
  cv.held_out.sum_sq.assign(2 * B, 0);
  cv.held_out.count.assign(2 * B, 0);
  for (int parity = 0; parity < 2; ++parity) {
    const FitOutcome& fit = *folds[parity];
    cv.fold_params.push_back(fit.params);
    cv.fold_coef.push_back(fit.coef);
    const BlockScores s = ScoreBlocks(d, fit.coef, fit.effects, true, eps);
    for (int j = 0; j < 2; ++j)
      for (int b = 0; b < B; ++b)
        if (b % 2 != parity) {
          const int i = j * B + b;
          cv.held_out.sum[i] = s.sum[i];
          cv.held_out.sum_sq[i] = s.sum_sq[i];
          cv.held_out.count[i] = s.count[i];
        }
  }
  const double n = std::accumulate(cv.held_out.count.begin(), cv.held_out.count.end(), 0.0);
  cv.mse = std::accumulate(cv.held_out.sum_sq.begin(), cv.held_out.sum_sq.end(), 0.0) / n;
  cv.e = std::accumulate(cv.held_out.sum.begin(), cv.held_out.sum.end(), 0.0) / n;
  cv.ok = std::isfinite(cv.mse);
  return cv;
}

bool FoldsStayedAtStart(Effect e, const ModelCv& cv, const std::vector<std::vector<double>>& starts) {
  return cv.fold_params.size() == 2 && StayedAtStart(e, cv.fold_params[0], starts) &&
         StayedAtStart(e, cv.fold_params[1], starts);
}

bool LostToTheBase(const FitOutcome& effect_fit, const FitOutcome& base_fit) {
  return effect_fit.train_mse > base_fit.train_mse;
}
FitOutcome BaseWithNeutralEffect(const FitOutcome& base_fit, Effect e) {
  FitOutcome n = base_fit;
  n.effects = EffectParams{};
  n.params = InfoOf(e).neutral;
  return n;
}

FitSpec CvSpec(bool has_effect, Effect e, const Coefficients& start, double ridge_mm, int parity,
               const DiagnoseOptions& o) {
  FitSpec fs;
  fs.has_effect = has_effect;
  fs.effect = e;
  if (has_effect) fs.effect_starts = EffectStarts(e);
  fs.start = start;
  fs.prior = start;
  fs.prior_weight = ridge_mm;
  fs.blocked = true;
  fs.train_parity = parity;
  fs.iterations = o.grg_iterations;
  fs.epsilon = o.epsilon;
  return fs;
}

std::vector<Effect> TestedEffects(const DiagnoseOptions& o) {
  std::vector<Effect> out;
  if (o.effects.empty()) {
    for (int i = 0; i < kNumCatalogue; ++i) out.push_back(static_cast<Effect>(i));
  } else {
    for (const auto& n : o.effects) out.push_back(*ParseEffectName(n));
  }
  return out;
}

bool Testable(const EffectData& d, Effect e, std::string* note) {
  if (e == Effect::kGapOffset && d.worms[0].drive->gaps().empty() && d.worms[1].drive->gaps().empty()) {
    *note = "not testable: neither recording has missing frames";
    return false;
  }
  return true;
}

std::vector<int> DiagnosisRun::Rank(std::vector<int> v, const std::vector<std::optional<ModelCv>>* refits) const {
  auto score = [&](int i) {
    double mse = data_cv.effects[i].mse;
    if (refits && o.score_refined_fit && (*refits)[i] && (*refits)[i]->mse > 0) mse = std::min(mse, (*refits)[i]->mse);
    return Penalised(mse, static_cast<int>(InfoOf(tested[i]).params.size()), o.penalty_per_param);
  };
  std::stable_sort(v.begin(), v.end(), [&](int a, int b) { return score(a) < score(b); });
  return v;
}

namespace {

// Where a fit of the CV batch goes: replicate, model (-1 base CV, -2 the replicate's
// base refit for its "where", else an index into `tested`) and fold.
struct Slot {
  int replicate, model, parity;
};

// The batch: on the data and on every replicate, the base model's and every testable
// effect's two fold fits, plus each replicate's base refit. All are independent given
// the base fit.
std::vector<FitTask> CvTasks(const DiagnosisRun& run, std::vector<Slot>* slots) {
  const DiagnoseOptions& o = run.o;
  std::vector<FitTask> tasks;
  for (int r = 0; r <= o.null_replicates; ++r) {
    auto add = [&](int model, const FitSpec& spec, int parity) {
      FitTask t;
      t.replicate = r;
      t.null_base = run.cv_base;
      t.null_sigma = run.out.noise_sigma;
      t.spec = spec;
      tasks.push_back(t);
      slots->push_back({r, model, parity});
    };
    if (r > 0) {
      FitSpec fs;
      fs.start = run.cv_base;
      fs.blocked = false;
      fs.iterations = o.grg_iterations;
      fs.epsilon = o.epsilon;
      add(-2, fs, -1);
    }
    for (int parity = 0; parity < 2; ++parity)
      add(-1, CvSpec(false, Effect::kBodyGradient, run.cv_base, run.ridge_mm, parity, o), parity);
    for (size_t i = 0; i < run.tested.size(); ++i) {
      std::string note;
      if (!Testable(run.data, run.tested[i], &note)) continue;
      for (int parity = 0; parity < 2; ++parity)
        add(static_cast<int>(i), CvSpec(true, run.tested[i], run.cv_base, run.ridge_mm, parity, o), parity);
    }
  }
  return tasks;
}

}  // namespace

Status CrossValidate(DiagnosisRun* run) {
  const DiagnoseOptions& o = run->o;
  std::vector<Slot> slots;
  const std::vector<FitTask> tasks = CvTasks(*run, &slots);
  run->StartFits("fits", static_cast<int>(tasks.size()));
  auto fits = run->RunFits(tasks);
  if (!fits.ok()) return fits.status();
  if (fits->size() != tasks.size()) return Status::Internal("the fit runner returned the wrong number of fits");
  if (run->Cancelled()) return Status::Cancelled("diagnosis cancelled");

  // Gather: each model's CV per replicate, scored here on the replicate's data.
  std::vector<CvSweep> sweeps(o.null_replicates + 1);
  run->null_where.assign(o.null_replicates, {});
  for (auto& sw : sweeps) sw.effects.resize(run->tested.size());
  std::map<std::pair<int, int>, std::array<const FitOutcome*, 2>> folds;
  for (size_t k = 0; k < tasks.size(); ++k) {
    const Slot& sl = slots[k];
    if (sl.model == -2)
      run->null_where[sl.replicate - 1] = ComputeWhere(run->null_data[sl.replicate - 1], (*fits)[k].coef, o.epsilon,
                                                       run->out.gait_hz);
    else
      folds[{sl.replicate, sl.model}][sl.parity] = &(*fits)[k];
  }
  // Lost effect fold fits are replaced by the base's (LostToTheBase).
  std::deque<FitOutcome> nested;
  if (o.nested_fallback)
    for (auto& [key, f] : folds) {
      const auto [r, model] = key;
      if (model < 0) continue;
      const auto base_folds = folds.find({r, -1});
      if (base_folds == folds.end()) continue;
      for (int parity = 0; parity < 2; ++parity) {
        const FitOutcome* b = base_folds->second[parity];
        if (!f[parity] || !b || !LostToTheBase(*f[parity], *b)) continue;
        nested.push_back(BaseWithNeutralEffect(*b, run->tested[model]));
        f[parity] = &nested.back();
      }
    }
  for (const auto& [key, f] : folds) {
    const auto [r, model] = key;
    ModelCv cv = AssembleCv(*run->replicate_data[r], f, o.epsilon);
    (model < 0 ? sweeps[r].base : sweeps[r].effects[model]) = std::move(cv);
  }
  run->data_cv = std::move(sweeps[0]);
  run->null_cv.assign(std::make_move_iterator(sweeps.begin() + 1), std::make_move_iterator(sweeps.end()));

  // Parameters: the mean of the two folds' estimates (each fitted on half the blocks);
  // their difference enters the interval. (A third, full-data fit per effect would cost
  // half as much again as the whole CV; the closest effect gets one in RefitClosest.)
  run->full.assign(run->tested.size(), {});
  for (size_t i = 0; i < run->tested.size(); ++i) {
    const ModelCv& m = run->data_cv.effects[i];
    if (!m.ok || m.fold_params.size() != 2) continue;
    run->full[i].coef = m.fold_coef[0];
    for (size_t k = 0; k < m.fold_params[0].size(); ++k)
      run->full[i].params.push_back(0.5 * (m.fold_params[0][k] + m.fold_params[1][k]));
  }
  for (size_t i = 0; i < run->tested.size(); ++i)
    if (run->data_cv.effects[i].ok && run->full[i].params.size() == InfoOf(run->tested[i]).params.size())
      run->ranked.push_back(static_cast<int>(i));
  run->ranked = run->Rank(std::move(run->ranked), nullptr);
  return Status::Ok();
}

// How far: the fold fits above are held near the base's coefficients, which compensated
// for the missing effect, so with the effect added they cannot move to where they belong.
// The closest effects are therefore refitted on their own: all blocks with the
// coefficients free, then two fold fits started from and held near that fit. Their
// held-out scores give "how far", and the effect's score when they beat its base-centred
// one (DiagnoseOptions::score_refined_fit; docs/decisions/0019-own-refit.md).
Status RefitClosest(DiagnosisRun* run) {
  const DiagnoseOptions& o = run->o;
  const std::vector<Effect>& tested = run->tested;
  run->own.assign(tested.size(), std::nullopt);
  run->refit_note.assign(tested.size(), "");
  run->own_unmoved.assign(tested.size(), false);
  if (o.refine_top <= 0) return Status::Ok();
  const std::vector<int> order(run->ranked.begin(),
                               run->ranked.begin() + std::min<size_t>(run->ranked.size(), o.refine_top));
  std::vector<FitTask> all_blocks;
  for (int i : order) {
    FitTask t;
    t.spec = CvSpec(true, tested[i], run->cv_base, 0, -1, o);
    t.spec.effect_starts = {run->full[i].params};
    // The coefficients may have to move far from the base's compensation.
    t.spec.extra_starts = FurtherStarts(run->cv_base, o);
    t.spec.iterations = 2 * o.grg_iterations;
    all_blocks.push_back(t);
  }
  run->StartFits("refits", static_cast<int>(3 * all_blocks.size()));  // the refits, then two folds each
  auto fitted = run->RunFits(all_blocks);
  Result<std::vector<FitOutcome>> folded = fitted.status();
  if (fitted.ok()) {
    std::vector<FitTask> fold_tasks;
    for (size_t k = 0; k < order.size(); ++k)
      for (int parity = 0; parity < 2; ++parity) {
        FitTask t;
        t.spec = CvSpec(true, tested[order[k]], (*fitted)[k].coef, run->ridge_mm, parity, o);
        t.spec.effect_starts = {(*fitted)[k].params};
        fold_tasks.push_back(t);
      }
    folded = run->RunFits(fold_tasks);
  }
  if (run->Cancelled()) return Status::Cancelled("diagnosis cancelled");
  // The refits only refine the answer: a free fit can end where nothing simulates, and
  // then the base-centred fits stand.
  if (!folded.ok() && folded.status().code() == Status::Code::kCancelled) return folded.status();
  if (!folded.ok())
    for (int i : order)
      run->refit_note[i] = "its own refit failed (" + folded.status().message() +
                           "), so it is scored from the base-centred fits";
  for (size_t k = 0; folded.ok() && k < order.size(); ++k) {
    const int i = order[k];
    ModelCv cv = AssembleCv(run->data, {&(*folded)[2 * k], &(*folded)[2 * k + 1]}, o.epsilon);
    if (!cv.ok) continue;
    run->own_unmoved[i] = StayedAtStart(tested[i], (*fitted)[k].params, {run->full[i].params}) &&
                          FoldsStayedAtStart(tested[i], cv, {(*fitted)[k].params});
    run->full[i].coef = (*fitted)[k].coef;
    run->full[i].params = (*fitted)[k].params;
    run->own[i] = std::move(cv);
  }
  return Status::Ok();
}

namespace {

// Effect i's scores, estimate and interval as Decide and the report need them.
EffectFit ScoresOf(const DiagnosisRun& run, size_t i) {
  const std::vector<Effect>& tested = run.tested;
  const EffectInfo& info = InfoOf(tested[i]);
  EffectFit f;
  f.name = info.name;
  for (auto* p : info.params) f.param_names.push_back(p);
  f.extra_params = static_cast<int>(info.params.size());
  f.testable = Testable(run.data, tested[i], &f.note);
  if (!f.testable || !run.data_cv.effects[i].ok) {
    if (f.note.empty()) f.note = "the fit failed";
    f.testable = false;
    return f;
  }
  const ModelCv& m = run.data_cv.effects[i];
  const std::optional<ModelCv>& own = run.own[i];
  f.coef = run.full[i].coef;
  f.params = run.full[i].params;
  f.cv_mse = m.mse;
  f.cv_e_mm = m.e;
  f.block_sum.assign(m.held_out.sum.begin(), m.held_out.sum.end());
  f.block_count.assign(m.held_out.count.begin(), m.held_out.count.end());
  if (own) {
    f.refined = true;
    f.own_cv_mse = own->mse;
    f.own_cv_e_mm = own->e;
    f.own_block_sum.assign(own->held_out.sum.begin(), own->held_out.sum.end());
  }
  f.simex_mse = run.simex_mse[i];
  f.simex_own_mse = run.simex_own_mse[i];
  if (!run.refit_note[i].empty()) f.note = run.refit_note[i];
  const ModelCv& spread = own ? *own : m;  // the folds the estimate comes from
  std::vector<std::vector<double>> np(f.extra_params);
  for (const CvSweep& n : run.null_cv) {
    if (!n.effects[i].ok) continue;
    f.null_improvements.push_back(n.effects[i].mse / n.base.mse);  // ratios; penalised in Decide
    for (const auto& fp : n.effects[i].fold_params)
      for (int k = 0; k < f.extra_params && k < static_cast<int>(fp.size()); ++k) np[k].push_back(fp[k]);
  }
  // Not estimated: both base-centred folds ended at one of their starts, and so did the
  // own refit's chain where there is one.
  f.estimated = !(FoldsStayedAtStart(tested[i], m, EffectStarts(tested[i])) && (!own || run.own_unmoved[i]));
  for (int k = 0; k < f.extra_params; ++k) {
    const double sd_null = Sd(np[k]) / std::sqrt(2.0);  // of a two-fold mean
    f.null_param_sd.push_back(sd_null);
    double sd_fold = 0;
    if (spread.fold_params.size() == 2 && spread.fold_params[0].size() > static_cast<size_t>(k))
      sd_fold = std::abs(spread.fold_params[0][k] - spread.fold_params[1][k]) / 2;  // sd of the mean of two
    const double half = 2 * std::sqrt(sd_null * sd_null + sd_fold * sd_fold);
    f.param_lo.push_back(f.estimated ? f.params[k] - half : info.lower[k]);
    f.param_hi.push_back(f.estimated ? f.params[k] + half : info.upper[k]);
  }
  return f;
}

}  // namespace

void CollectScores(DiagnosisRun* run) {
  Diagnosis& out = run->out;
  const ModelCv& base = run->data_cv.base;
  out.base_cv.name = "base";
  out.base_cv.coef = out.base;
  out.base_cv.cv_mse = out.base_cv.cv_score = base.mse;
  out.base_cv.cv_e_mm = base.e;
  out.base_cv.block_sum.assign(base.held_out.sum.begin(), base.held_out.sum.end());
  out.base_cv.block_count.assign(base.held_out.count.begin(), base.held_out.count.end());
  std::vector<double> null_s0, null_e0;
  for (const CvSweep& n : run->null_cv) {
    null_s0.push_back(n.base.mse);
    null_e0.push_back(n.base.e);
  }
  out.null_base_cv_mses = null_s0;
  out.null_base_cv_mse = Mean(null_s0);
  out.null_base_cv_sd = Sd(null_s0);
  out.null_base_cv_e = Mean(null_e0);
  for (size_t i = 0; i < run->tested.size(); ++i) out.effects.push_back(ScoresOf(*run, i));
}

}  // namespace wormdrag::diagnose::internal
