#include "proto/result_convert.h"

#include <cmath>
#include <filesystem>
#include <limits>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/result_text.h"
#include "core/diagnose/diagnosis.h"
#include "core/jobs/estimate_job.h"
#include "tests/integration/small_pair.h"

namespace wormdrag::rpc {
namespace {

// Every scalar leaf of a JSON document (array elements and object values, recursively).
int Leaves(const nlohmann::json& j) {
  if (j.is_object() || j.is_array()) {
    int n = 0;
    for (const auto& v : j) n += Leaves(v);
    return n;
  }
  return 1;
}

// A diagnosis with every optional part of its document present: a measured gap
// signature, a refined effect with SIMEX, an untestable one, undefined and infinite values.
diagnose::Diagnosis FullDiagnosis() {
  diagnose::Diagnosis d;
  d.names = {"a.csv", "b \"quoted\".csv"};
  d.body_length = 1.0;
  d.noise_sigma = 0.002;
  d.gait_hz = 0.5;
  d.span_s = 5;
  d.blocks = 10;
  d.cautions = {"short recording"};
  d.gap_signature = {3, 12, 0.4, 0.1, 0.3, 0.05};
  d.base = {0.5, 0.2, 0.005, 0.002};
  d.cv_base = {0.6, 0.2, 0.005, 0.002};
  d.base_e_mm = 0.01;
  d.null_gait_excess = {1.1, 12.0};
  d.where = {{"along the body", "mm", {{"head", 0.01, 0.004, 0.006}, {"tail", 0.002, 0.004, 0.006}}}};
  diagnose::EffectFit lag;
  lag.name = "lag";
  lag.param_names = {"lag_s"};
  lag.coef = {0.5, 0.2, 0.005, 0.002};
  lag.params = {0.05};
  lag.param_lo = {0.04};
  lag.param_hi = {std::numeric_limits<double>::infinity()};
  lag.null_param_sd = {0.003};
  lag.cv_mse = 1e-5;
  lag.improvement = 0.3;
  lag.significant = true;
  lag.refined = true;
  lag.own_cv_mse = 9e-6;
  lag.scored_own = true;
  lag.simex_mse = {1e-5, 2e-5};
  lag.simex_own_mse = {1e-5};
  lag.simex_gain = 0.2;
  diagnose::EffectFit gap;
  gap.name = "gap_offset";
  gap.testable = false;
  gap.note = "no runs of missing frames";
  d.effects = {lag, gap};
  d.verdict = "lag";
  d.verdict_set = {"lag"};
  d.confidence = "clear";
  d.explanation = "The body lags.\nSecond line.";
  d.e_before = 0.01;
  d.e_after = 0.005;
  d.shrink_mm = 0.005;
  d.share_of_gap = std::numeric_limits<double>::quiet_NaN();
  return d;
}

TEST(ResultConvert, EveryKeyOfADiagnosisHasItsField) {
  const diagnose::Diagnosis d = FullDiagnosis();
  const std::string doc = d.ToJson();
  v2::DiagnosisResult r;
  Status st = ResultFromJson(doc, &r, {.strict = true});
  ASSERT_TRUE(st.ok()) << st.ToString();
  // Each leaf of the document is one field of the message (an effect's parameters add
  // their names as leaves).
  const nlohmann::json back = nlohmann::json::parse(ResultToJson(r));
  EXPECT_EQ(Leaves(back), Leaves(nlohmann::json::parse(doc)) + 1);
  EXPECT_EQ(r.names(1), "b \"quoted\".csv");
  EXPECT_EQ(r.explanation(), d.explanation);
  EXPECT_EQ(r.gap_signature().runs(), 3);
  ASSERT_EQ(r.which().effects_size(), 2);
  const v2::EffectScore& e = r.which().effects(0);
  ASSERT_EQ(e.params_size(), 1);
  EXPECT_EQ(e.params(0).name(), "lag_s");
  EXPECT_DOUBLE_EQ(e.params(0).value(), 0.05);
  EXPECT_TRUE(e.simex().own_fit_on_copies());
  EXPECT_FALSE(r.which().effects(1).testable());
  EXPECT_FALSE(r.which().effects(1).has_cv_mse_mm2());  // not written for an untestable effect
  EXPECT_TRUE(r.how_far().has_share_of_gap_above_noise());
  EXPECT_TRUE(std::isnan(r.how_far().share_of_gap_above_noise()));
  EXPECT_EQ(back["how_far"]["share_of_gap_above_noise"], "NaN");
  EXPECT_NE(cli::DiagnosisResultText(r).find("verdict: lag"), std::string::npos);
}

TEST(ResultConvert, AStoredEstimateConvertsWholeAndPrints) {
  const auto dir = std::filesystem::temp_directory_path() / "wormdrag_result_convert_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  auto store = JobStore::Open((dir / "jobs.db").string());
  ASSERT_TRUE(store.ok());
  JobOptions o;
  o.estimate.search.n_max = 3;
  o.estimate.eval.t_max = 0.5;
  o.bootstrap.replicates = 19;
  bool reused = false;
  auto id = SubmitEstimateJob(**store, itest::SmallPair(0.5), o, false, &reused);
  ASSERT_TRUE(id.ok()) << id.status().ToString();
  ASSERT_TRUE(RunEstimateJob(**store, *id, LocalEvaluatorFactory(2)).ok());
  const std::string doc = (*store)->GetJob(*id)->result_json;

  auto typed = cli::TypedResult("estimate", doc);
  ASSERT_TRUE(typed.ok()) << typed.status().ToString();
  v2::EstimateResult strict;
  Status st = ResultFromJson(doc, &strict, {.strict = true});
  ASSERT_TRUE(st.ok()) << st.ToString();
  ASSERT_TRUE(typed->has_estimate());
  EXPECT_EQ(typed->estimate().SerializeAsString(), strict.SerializeAsString());
  const nlohmann::json j = nlohmann::json::parse(doc);
  EXPECT_EQ(Leaves(nlohmann::json::parse(cli::ResultJson(*typed))), Leaves(j));
  EXPECT_EQ(strict.estimate().mu_n(), j["estimate"]["mu_n"].get<double>());
  EXPECT_EQ(strict.identifiability().hessian_log_size(), static_cast<int>(j["identifiability"]["hessian_log"].size()));
  EXPECT_EQ(strict.identifiability().scale_profile(0).e_mm(),
            j["identifiability"]["scale_profile"][0][1].get<double>());
  ASSERT_TRUE(strict.has_bootstrap());
  EXPECT_EQ(strict.bootstrap().fits_size(), static_cast<int>(j["bootstrap"]["fits"].size()));
  const std::string text = cli::ResultText(*typed);
  EXPECT_NE(text.find("friction per link: mu_n = "), std::string::npos) << text;
  EXPECT_NE(text.find("bootstrap refits"), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

TEST(ResultConvert, ShapesThatDoNotFitAreNamed) {
  v2::EstimateResult r;
  Status st = ResultFromJson(R"({"estimate":{"mu_n":"x"}})", &r);
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("result.estimate.mu_n"), std::string::npos) << st.ToString();
  EXPECT_FALSE(ResultFromJson(R"({"phases":[{"sets":1.5}]})", &r).ok());
  EXPECT_FALSE(ResultFromJson("not json", &r).ok());
  // An unknown key: skipped by default (results of other versions), refused when strict.
  EXPECT_TRUE(ResultFromJson(R"({"future_key":1,"skill":0.5})", &r).ok());
  EXPECT_DOUBLE_EQ(r.skill(), 0.5);
  st = ResultFromJson(R"({"future_key":1})", &r, {.strict = true});
  EXPECT_NE(st.message().find("result.future_key"), std::string::npos) << st.ToString();
  // "inf" is an infinity, null a NaN, a null message stays unset.
  ASSERT_TRUE(ResultFromJson(R"({"bootstrap":{"K_mu":{"hi":"inf","lo":null}}})", &r).ok());
  EXPECT_TRUE(std::isinf(r.bootstrap().k_mu().hi()));
  EXPECT_TRUE(std::isnan(r.bootstrap().k_mu().lo()));
  ASSERT_TRUE(ResultFromJson(R"({"bootstrap":{"smoothing_check":[{"lambda_scale":10,"fit":null}]}})", &r).ok());
  EXPECT_FALSE(r.bootstrap().smoothing_check(0).has_fit());
}

}  // namespace
}  // namespace wormdrag::rpc
