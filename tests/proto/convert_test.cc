// Options travel from the CLI to the coordinator as EstimateOptions: every option of
// `wormdrag submit` must arrive, or a remote job silently runs with defaults.
#include "proto/convert.h"

#include <cmath>

#include <gtest/gtest.h>

#include "client/cli.h"
#include "client/job_flags.h"
#include "core/jobs/bootstrap_run.h"
#include "wormdrag/v2/worker.pb.h"

namespace wormdrag {
namespace {

JobOptions AcrossTheWire(const JobOptions& o) {
  v2::EstimateOptions p;
  rpc::OptionsToProto(o, &p);
  auto back = rpc::OptionsFromProto(p);
  EXPECT_TRUE(back.ok()) << back.status().ToString();
  return back.ok() ? *back : JobOptions();
}

TEST(ConvertTest, EveryEstimationOptionSurvivesTheWire) {
  JobOptions o;
  o.estimate.search.n_max = 4;
  o.estimate.search.abandon = false;
  o.estimate.eval.t_max = 1.5;
  o.estimate.eval.restart_every = 0.5;
  o.smoothing = SmoothingMethod::kLowpass;
  o.lowpass_hz = 3;
  o.causal_filter = true;
  o.spline.order = 2;
  o.bootstrap.replicates = 0;
  o.bootstrap.level = 0.8;
  o.bootstrap.seed = 7;
  ASSERT_NE(o.ToJson(), JobOptions().ToJson());
  EXPECT_EQ(AcrossTheWire(o).ToJson(), o.ToJson());
}

// What `wormdrag submit --bootstrap 0 --smoothing lowpass` asks for is what the coordinator runs.
TEST(ConvertTest, SubmitFlagsReachTheCoordinator) {
  auto args = cli::Args::Parse({"--bootstrap", "0", "--smoothing", "lowpass", "--spline-order", "2"},
                               cli::JobOptionSpecs());
  ASSERT_TRUE(args.ok()) << args.status().ToString();
  auto o = cli::JobOptionsFromArgs(*args);
  ASSERT_TRUE(o.ok()) << o.status().ToString();
  const JobOptions remote = AcrossTheWire(*o);
  EXPECT_EQ(remote.bootstrap.replicates, 0);
  EXPECT_EQ(remote.smoothing, SmoothingMethod::kLowpass);
  EXPECT_EQ(remote.spline.order, 2);
  EXPECT_EQ(remote.ToJson(), o->ToJson());
}

TEST(ConvertTest, UnsetFieldsTakeTheDefaults) {
  auto o = rpc::OptionsFromProto(v2::EstimateOptions());
  ASSERT_TRUE(o.ok()) << o.status().ToString();
  EXPECT_EQ(o->ToJson(), JobOptions().ToJson());
}

TEST(ConvertTest, BadSmoothingOrBootstrapIsRejected) {
  v2::EstimateOptions p;
  p.set_smoothing("median");
  EXPECT_FALSE(rpc::OptionsFromProto(p).ok());
  v2::EstimateOptions q;
  q.set_bootstrap_replicates(-1);
  EXPECT_FALSE(rpc::OptionsFromProto(q).ok());
  v2::EstimateOptions r;
  r.set_bootstrap_level(1.5);
  EXPECT_FALSE(rpc::OptionsFromProto(r).ok());
}

// A job's stored options reach a worker and the CLI typed, and turn back into exactly
// the stored canonical text, so what runs, and what is shown, is what was stored.
TEST(ConvertTest, StoredOptionsTextSurvivesTheTypedWire) {
  JobOptions o;
  o.estimate.eval.points = {2, 9};
  o.estimate.eval.knot_rate = 450;
  o.estimate.eval.t_max = 1.0 / 3;
  o.estimate.search.d_mu = 0.1;
  o.estimate.phase3.method = Phase3Method::kBobyqa;
  o.bootstrap.seed = 18446744073709551557ull;
  for (const JobOptions& stored : {JobOptions(), o}) {
    v2::Task task;
    ASSERT_TRUE(rpc::SetJobOptions(stored.ToJson(), false, &task).ok());
    ASSERT_TRUE(task.has_estimate_options());
    auto text = rpc::JobOptionsText(task);
    ASSERT_TRUE(text.ok()) << text.status().ToString();
    EXPECT_EQ(*text, stored.ToJson());
  }
  // Text stored before the knot rate existed runs as JobOptionsFromJson reads it.
  std::string old = o.ToJson();
  const size_t at = old.find(",\"knot_rate\":");
  old.erase(at, old.find(',', at + 1) - at);
  v2::Job job;
  ASSERT_TRUE(rpc::SetJobOptions(old, false, &job).ok());
  EXPECT_EQ(*rpc::JobOptionsText(job), JobOptionsFromJson(old)->ToJson());
}

// A diagnosis job's stored options, tuning included, reach a worker typed and turn back
// into the stored text; unreadable stored options are refused, not sent as defaults.
TEST(ConvertTest, DiagnosisOptionsSurviveTheTypedWireAndBadStoredTextIsRefused) {
  diagnose::DiagnoseOptions o;
  o.blocks = 4;
  o.noise_sigma = 0.01;
  o.effects = {"time_drift", "stiction"};
  o.cv_ridge = 1.0 / 3;
  o.refine_top = 2;
  o.min_improvement = 0.2;
  o.require_shrink_interval = false;
  o.simex_min_keep = 0.5;
  o.clear_margin = 3;
  o.smoothing = SmoothingMethod::kAuto;
  o.spline.order = 2;
  o.seed = 18446744073709551557ull;
  for (const diagnose::DiagnoseOptions& stored : {diagnose::DiagnoseOptions(), o}) {
    ASSERT_TRUE(stored.Validate().ok()) << stored.Validate().ToString();
    v2::Task task;
    ASSERT_TRUE(rpc::SetJobOptions(DiagnoseOptionsToJson(stored), true, &task).ok());
    ASSERT_TRUE(task.has_diagnose_options());
    auto text = rpc::JobOptionsText(task);
    ASSERT_TRUE(text.ok()) << text.status().ToString();
    EXPECT_EQ(*text, DiagnoseOptionsToJson(stored));
  }
  v2::Job bad;
  EXPECT_FALSE(rpc::SetJobOptions("{\"eval\":3}", false, &bad).ok());
  EXPECT_FALSE(bad.has_estimate_options());
  EXPECT_FALSE(rpc::JobOptionsText(bad).ok());
  EXPECT_FALSE(rpc::SetJobOptions("[1]", true, &bad).ok());
  v2::DiagnoseOptions nan;
  nan.set_min_improvement(std::nan(""));
  EXPECT_FALSE(rpc::DiagnoseOptionsFromProto(nan).ok());
  v2::DiagnoseOptions spline;
  spline.set_smoothing("spline");
  EXPECT_FALSE(rpc::DiagnoseOptionsFromProto(spline).ok());
}

// What `wormdrag diagnose --server` is given, tuning flags included, is what the
// coordinator runs.
TEST(ConvertTest, EveryDiagnosisOptionSurvivesTheWire) {
  diagnose::DiagnoseOptions o;
  o.cv_ridge = 0.25;
  o.refine_top = 3;
  o.require_gap_signature = false;
  o.clear_margin = 1.5;
  o.base_multistart = false;
  o.false_alarm_rate = 0.01;
  o.smoothing = SmoothingMethod::kNone;
  v2::DiagnoseOptions p;
  rpc::DiagnoseOptionsToProto(o, &p);
  auto back = rpc::DiagnoseOptionsFromProto(p);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(DiagnoseOptionsToJson(*back), DiagnoseOptionsToJson(o));
}

// A bootstrap refit reaches the worker typed as the task the coordinator stored as JSON,
// every value bit for bit, and what the JSON reader refuses is refused typed too.
TEST(ConvertTest, BootstrapRefitSurvivesTheTypedWire) {
  ReplicateTask t{12, {{0.62, 0.24, 0.006, 0.002}, 0.1 / 3}, Coefficients{1, 0.1, 0.01, 1.0 / 3}, {0.004, 0.005}};
  for (int variant = 0; variant < 3; ++variant) {
    if (variant == 1) t.model.reset();
    if (variant == 2) t.refit_data = true, t.smoothing_scale = 0.1;
    auto stored = ReplicateTaskFromJson(ReplicateTaskToJson(t));
    ASSERT_TRUE(stored.ok()) << stored.status().ToString();
    v2::ReplicateTask p;
    rpc::ReplicateTaskToProto(*stored, &p);
    auto back = rpc::ReplicateTaskFromProto(p);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_EQ(ReplicateTaskToJson(*back), ReplicateTaskToJson(*stored)) << variant;
  }
  v2::ReplicateTask bad;
  rpc::ReplicateTaskToProto(t, &bad);
  bad.mutable_model()->set_mu_t(-1);
  EXPECT_FALSE(rpc::ReplicateTaskFromProto(bad).ok());
  bad.mutable_model()->set_mu_t(1);
  bad.set_smoothing_scale(0);
  EXPECT_FALSE(rpc::ReplicateTaskFromProto(bad).ok());
  bad.set_smoothing_scale(1);
  bad.clear_noise_mm();
  EXPECT_FALSE(rpc::ReplicateTaskFromProto(bad).ok());
  EXPECT_FALSE(rpc::ReplicateTaskFromProto(v2::ReplicateTask()).ok());
}

// A diagnosis fit reaches the worker typed as the fit the coordinator stored as JSON,
// every value bit for bit, and what the JSON reader refuses is refused typed too.
TEST(ConvertTest, DiagnosisFitSurvivesTheTypedWire) {
  diagnose::FitTask t;
  t.replicate = 3;
  t.null_base = {0.62, 0.24, 0.006, 1.0 / 3};
  t.null_sigma = 0.01 / 3;
  t.spec.has_effect = true;
  t.spec.effect = diagnose::Effect::kFlow;
  t.spec.effect_starts = {{0, 0}, {0.1 / 3, -0.2}};
  t.spec.start = {0.5, 0.2, 0.005, 0.002};
  t.spec.extra_starts = {{1, 2, 3, 4}};
  t.spec.prior = {0.4, 0.3, 0.004, 0.003};
  t.spec.prior_weight = 0.5;
  t.spec.train_parity = 1;
  t.spec.iterations = 7;
  for (int variant = 0; variant < 2; ++variant) {
    if (variant == 1) t.spec = diagnose::FitSpec();  // the base model: no effect
    auto stored = FitTaskFromJson(FitTaskToJson(t));
    ASSERT_TRUE(stored.ok()) << stored.status().ToString();
    v2::FitTask p;
    rpc::FitTaskToProto(*stored, &p);
    auto back = rpc::FitTaskFromProto(p);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_EQ(FitTaskToJson(*back), FitTaskToJson(*stored)) << variant;
  }
  v2::FitTask bad;
  rpc::FitTaskToProto(t, &bad);
  bad.set_effect("flow");
  EXPECT_TRUE(rpc::FitTaskFromProto(bad).ok());
  bad.add_effect_starts()->add_values(1);  // flow takes 2 parameters
  EXPECT_FALSE(rpc::FitTaskFromProto(bad).ok());
  bad.clear_effect_starts();
  bad.set_effect("no_such_effect");
  EXPECT_FALSE(rpc::FitTaskFromProto(bad).ok());
  bad.set_effect("");
  bad.set_iterations(0);
  EXPECT_FALSE(rpc::FitTaskFromProto(bad).ok());
  EXPECT_FALSE(rpc::FitTaskFromProto(v2::FitTask()).ok());
}

}  // namespace
}  // namespace wormdrag
