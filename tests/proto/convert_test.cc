// Options travel from the CLI to the coordinator as EstimateOptions: every option of
// `wormdrag submit` must arrive, or a remote job silently runs with defaults.
#include "proto/convert.h"

#include <gtest/gtest.h>

#include "client/cli.h"
#include "client/job_flags.h"

namespace wormdrag {
namespace {

JobOptions AcrossTheWire(const JobOptions& o) {
  v1::EstimateOptions p;
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
  auto o = rpc::OptionsFromProto(v1::EstimateOptions());
  ASSERT_TRUE(o.ok()) << o.status().ToString();
  EXPECT_EQ(o->ToJson(), JobOptions().ToJson());
}

TEST(ConvertTest, BadSmoothingOrBootstrapIsRejected) {
  v1::EstimateOptions p;
  p.set_smoothing("median");
  EXPECT_FALSE(rpc::OptionsFromProto(p).ok());
  v1::EstimateOptions q;
  q.set_bootstrap_replicates(-1);
  EXPECT_FALSE(rpc::OptionsFromProto(q).ok());
  v1::EstimateOptions r;
  r.set_bootstrap_level(1.5);
  EXPECT_FALSE(rpc::OptionsFromProto(r).ok());
}

}  // namespace
}  // namespace wormdrag
