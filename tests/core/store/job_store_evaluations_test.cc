// The job store's evaluations and survivors: idempotent batches, exact round trips,
// lookups across jobs, ranking, and batches from many threads at once.
#include "core/store/job_store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "tests/core/store/store_testing.h"

namespace wormdrag {
namespace {

using store_testing::Eval;
using store_testing::JobStoreTest;
using store_testing::kInf;
using store_testing::RawConnection;
using store_testing::SetNumber;

TEST_F(JobStoreTest, PutEvaluationsIsIdempotentFirstValueWins) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 0.5), Eval(1, 2, 0.25)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 0.5), Eval(1, 2, 0.25)}).ok());  // the same batch again
  EXPECT_EQ(*store_->CountEvaluations(id), 2);

  // A different E for a stored set is ignored; the new set is added.
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, 99.0), Eval(1, 3, 0.75)}).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 3);
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  for (const EvaluationRecord& r : *all) {
    if (r.set == SetNumber(1)) { EXPECT_EQ(r.e, 0.5); }
  }

  // The same set in another phase is another evaluation.
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(2, 1, 0.4)}).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 4);
  EXPECT_EQ(*store_->CountEvaluations(id, 1), 3);
  EXPECT_EQ(*store_->CountEvaluations(id, 2), 1);
}

TEST_F(JobStoreTest, InfiniteERoundTrips) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutEvaluations(id, {Eval(1, 1, kInf), Eval(1, 2, 1.5)}).ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].e, 1.5);  // finite before infinite
  EXPECT_TRUE(std::isinf((*all)[1].e) && (*all)[1].e > 0) << (*all)[1].e;
  EXPECT_EQ((*all)[1].set, SetNumber(1));

  std::vector<std::optional<double>> found;
  ASSERT_TRUE(store_->LookupEvaluations("k", {SetNumber(1)}, &found).ok());
  ASSERT_TRUE(found[0].has_value());
  EXPECT_EQ(*found[0], kInf);

  RawConnection raw(path_);
  EXPECT_EQ(raw.QueryText("SELECT typeof(e) FROM evaluations WHERE e > 1e308"), "real");  // not NULL, not text
}

TEST_F(JobStoreTest, CoefficientsRoundTripBitExactly) {
  const int64_t id = CreateJob("k");
  const Coefficients awkward{0.1 + 0.2, 1.0 / 3.0, 5e-324, 1.7976931348623157e308};
  ASSERT_TRUE(store_->PutEvaluations(id, {EvaluationRecord{1, awkward, 0.1 * 3}}).ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  ASSERT_EQ(all->size(), 1u);
  EXPECT_EQ((*all)[0].set, awkward);
  EXPECT_EQ((*all)[0].e, 0.1 * 3);
  std::vector<std::optional<double>> found;
  ASSERT_TRUE(
      store_->LookupEvaluations("k", {awkward, Coefficients{0.3, 1.0 / 3.0, 5e-324, 1.7976931348623157e308}}, &found)
          .ok());
  EXPECT_TRUE(found[0].has_value());
  EXPECT_FALSE(found[1].has_value());  // 0.3 != 0.1 + 0.2: compared exactly
}

TEST_F(JobStoreTest, LookupFindsSetsOfAnyJobWithTheSameKeyOnly) {
  const int64_t first = CreateJob("key-A");
  const int64_t second = CreateJob("key-A");
  const int64_t other = CreateJob("key-B");
  ASSERT_TRUE(store_->PutEvaluations(first, {Eval(1, 1, 0.1), Eval(1, 2, 0.2)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(second, {Eval(2, 3, 0.3)}).ok());
  ASSERT_TRUE(store_->PutEvaluations(other, {Eval(1, 4, 0.4)}).ok());

  std::vector<std::optional<double>> found;
  ASSERT_TRUE(
      store_->LookupEvaluations("key-A", {SetNumber(1), SetNumber(3), SetNumber(4), SetNumber(5)}, &found).ok());
  ASSERT_EQ(found.size(), 4u);
  EXPECT_EQ(found[0], std::optional<double>(0.1));
  EXPECT_EQ(found[1], std::optional<double>(0.3));  // stored by the second job
  EXPECT_FALSE(found[2].has_value());               // stored under key-B
  EXPECT_FALSE(found[3].has_value());               // never evaluated

  ASSERT_TRUE(store_->LookupEvaluations("key-B", {SetNumber(1), SetNumber(4)}, &found).ok());
  ASSERT_EQ(found.size(), 2u);
  EXPECT_FALSE(found[0].has_value());
  EXPECT_EQ(found[1], std::optional<double>(0.4));

  ASSERT_TRUE(store_->LookupEvaluations("key-C", {}, &found).ok());
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(store_->LookupEvaluations("", {SetNumber(1)}, &found).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, EvaluationsBestFirstFilteredAndLimited) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_
                  ->PutEvaluations(id, {Eval(1, 1, 0.9), Eval(1, 2, 0.1), Eval(2, 3, 0.5), Eval(1, 4, kInf),
                                        Eval(2, 5, 0.05), Eval(1, 6, 0.3)})
                  .ok());
  auto all = store_->Evaluations(id);
  ASSERT_TRUE(all.ok());
  std::vector<double> es;
  for (const auto& r : *all) es.push_back(r.e);
  EXPECT_EQ(es, (std::vector<double>{0.05, 0.1, 0.3, 0.5, 0.9, kInf}));
  EXPECT_EQ((*all)[0].phase, 2);
  EXPECT_EQ((*all)[0].set, SetNumber(5));

  auto phase1 = store_->Evaluations(id, 1);
  ASSERT_TRUE(phase1.ok());
  es.clear();
  for (const auto& r : *phase1) {
    es.push_back(r.e);
    EXPECT_EQ(r.phase, 1);
  }
  EXPECT_EQ(es, (std::vector<double>{0.1, 0.3, 0.9, kInf}));

  auto best2 = store_->Evaluations(id, 1, 2);
  ASSERT_TRUE(best2.ok());
  ASSERT_EQ(best2->size(), 2u);
  EXPECT_EQ((*best2)[0].set, SetNumber(2));
  EXPECT_EQ((*best2)[1].set, SetNumber(6));

  auto none = store_->Evaluations(id, 3);
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

// A batch is one transaction: a bad row in the middle leaves none of it stored.
TEST_F(JobStoreTest, FailedBatchStoresNothing) {
  const int64_t id = CreateJob("k");
  std::vector<EvaluationRecord> batch;
  for (int i = 0; i < 100; ++i) batch.push_back(Eval(1, i, 0.01 * i));
  batch[50].e = std::numeric_limits<double>::quiet_NaN();  // SQLite would store NULL: rejected by NOT NULL
  Status s = store_->PutEvaluations(id, batch);
  EXPECT_EQ(s.code(), Status::Code::kInvalidArgument) << s.ToString();
  EXPECT_NE(s.message().find("evaluation 50 of 100"), std::string::npos) << s.ToString();
  EXPECT_EQ(*store_->CountEvaluations(id), 0);

  batch[50].e = 0.5;
  batch[99].phase = 0;  // violates CHECK (phase >= 1) on the last row
  EXPECT_FALSE(store_->PutEvaluations(id, batch).ok());
  EXPECT_EQ(*store_->CountEvaluations(id), 0);

  batch[99].phase = 1;
  ASSERT_TRUE(store_->PutEvaluations(id, batch).ok());  // the store is still usable
  EXPECT_EQ(*store_->CountEvaluations(id), 100);
}

// CreateJob writes the datasets, then the job; the job row is rejected by the
// schema's CHECK on kind, after both datasets were inserted in the transaction.
TEST_F(JobStoreTest, SurvivorsReplaceAndKeepRankOrder) {
  const int64_t id = CreateJob("k");
  // Rank order is the caller's, not E order.
  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 7, 0.3), Eval(1, 8, 0.1), Eval(1, 9, 0.2)}).ok());
  ASSERT_TRUE(store_->PutSurvivors(id, 2, {Eval(2, 1, 0.05)}).ok());
  auto d1 = store_->Survivors(id, 1);
  ASSERT_TRUE(d1.ok());
  ASSERT_EQ(d1->size(), 3u);
  EXPECT_EQ((*d1)[0].set, SetNumber(7));
  EXPECT_EQ((*d1)[1].set, SetNumber(8));
  EXPECT_EQ((*d1)[2].set, SetNumber(9));
  EXPECT_EQ((*d1)[1].e, 0.1);
  EXPECT_EQ((*d1)[0].phase, 1);

  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 2, 0.01), Eval(1, 3, 0.02)}).ok());
  d1 = store_->Survivors(id, 1);
  ASSERT_EQ(d1->size(), 2u);  // replaced, not appended
  EXPECT_EQ((*d1)[0].set, SetNumber(2));
  EXPECT_EQ((*d1)[1].set, SetNumber(3));
  EXPECT_EQ(store_->Survivors(id, 2)->size(), 1u);  // the other phase untouched

  ASSERT_TRUE(store_->PutSurvivors(id, 1, {}).ok());
  EXPECT_TRUE(store_->Survivors(id, 1)->empty());
  EXPECT_EQ(store_->PutSurvivors(id, 0, {}).code(), Status::Code::kInvalidArgument);
}

TEST_F(JobStoreTest, FailedSurvivorReplacementKeepsThePreviousOnes) {
  const int64_t id = CreateJob("k");
  ASSERT_TRUE(store_->PutSurvivors(id, 1, {Eval(1, 1, 0.1), Eval(1, 2, 0.2)}).ok());
  std::vector<EvaluationRecord> bad = {Eval(1, 3, 0.3), Eval(1, 4, std::numeric_limits<double>::quiet_NaN())};
  EXPECT_FALSE(store_->PutSurvivors(id, 1, bad).ok());
  auto d1 = store_->Survivors(id, 1);
  ASSERT_TRUE(d1.ok());
  ASSERT_EQ(d1->size(), 2u);
  EXPECT_EQ((*d1)[0].set, SetNumber(1));
  EXPECT_EQ((*d1)[1].set, SetNumber(2));
}

// ------------------------------------------------------------------ durability, threads, volume

TEST_F(JobStoreTest, ConcurrentBatchesFromFourThreadsLoseNothing) {
  const int64_t id = CreateJob("k");
  constexpr int kThreads = 4, kBatches = 20, kPerBatch = 50;
  std::atomic<int> failures{0};
  std::atomic<bool> writing{true};
  std::vector<std::thread> writers;
  for (int t = 0; t < kThreads; ++t) {
    writers.emplace_back([&, t] {
      for (int b = 0; b < kBatches; ++b) {
        std::vector<EvaluationRecord> batch;
        for (int i = 0; i < kPerBatch; ++i) {
          const int n = (t * kBatches + b) * kPerBatch + i;  // distinct across threads
          batch.push_back(Eval(1, n, 0.001 * n));
        }
        batch.push_back(Eval(1, -1 - b, 100.0 + t));  // the same sets from every thread
        if (!store_->PutEvaluations(id, batch).ok()) ++failures;
      }
    });
  }
  // A reader at the same time: it must never see an error.
  std::thread reader([&] {
    std::vector<std::optional<double>> found;
    while (writing) {
      if (!store_->CountEvaluations(id).ok()) ++failures;
      if (!store_->LookupEvaluations("k", {SetNumber(0), SetNumber(-1)}, &found).ok()) ++failures;
    }
  });
  for (auto& w : writers) w.join();
  writing = false;
  reader.join();

  EXPECT_EQ(failures.load(), 0);
  EXPECT_EQ(*store_->CountEvaluations(id), kThreads * kBatches * kPerBatch + kBatches);
  std::vector<Coefficients> shared;
  for (int b = 0; b < kBatches; ++b) shared.push_back(SetNumber(-1 - b));
  std::vector<std::optional<double>> found;
  ASSERT_TRUE(store_->LookupEvaluations("k", shared, &found).ok());
  for (const auto& e : found) {
    ASSERT_TRUE(e.has_value());
    EXPECT_TRUE(*e == 100.0 || *e == 101.0 || *e == 102.0 || *e == 103.0) << *e;  // one thread's value, whole
  }
}

TEST_F(JobStoreTest, TenThousandRowBatchInOneCall) {
  const int64_t id = CreateJob("k");
  constexpr int kRows = 10000;
  std::vector<EvaluationRecord> batch;
  batch.reserve(kRows);
  for (int i = 0; i < kRows; ++i) batch.push_back(Eval(1 + i % 3, i, i % 97 == 1 ? kInf : 1.0 + (i * 7919) % kRows));
  const auto start = std::chrono::steady_clock::now();
  Status s = store_->PutEvaluations(id, batch);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(s.ok()) << s.ToString();
  std::cout << "[ timing   ] PutEvaluations of " << kRows << " rows: " << seconds * 1e3 << " ms\n";
  RecordProperty("put_10000_ms", std::to_string(seconds * 1e3));

  EXPECT_EQ(*store_->CountEvaluations(id), kRows);
  std::vector<Coefficients> sets;
  for (int i = 0; i < kRows; ++i) sets.push_back(SetNumber(i));
  std::vector<std::optional<double>> found;
  const auto lookup_start = std::chrono::steady_clock::now();
  ASSERT_TRUE(store_->LookupEvaluations("k", sets, &found).ok());
  const double lookup_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - lookup_start).count();
  std::cout << "[ timing   ] LookupEvaluations of " << kRows << " sets: " << lookup_seconds * 1e3 << " ms\n";
  for (int i = 0; i < kRows; ++i) {
    ASSERT_TRUE(found[i].has_value()) << i;
    ASSERT_EQ(*found[i], batch[i].e) << i;
  }
  auto best = store_->Evaluations(id, 0, 3);
  ASSERT_TRUE(best.ok());
  ASSERT_EQ(best->size(), 3u);
  EXPECT_EQ((*best)[0].e, 1.0);  // (i * 7919) % 10000 == 0 only for i = 0
  EXPECT_LE((*best)[0].e, (*best)[1].e);
  EXPECT_LE((*best)[1].e, (*best)[2].e);
}

}  // namespace
}  // namespace wormdrag
