// What the job store's tests share: records to store, a second raw connection to the
// same file, and a fixture that opens a fresh store per test.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "core/store/job_store.h"

namespace wormdrag::store_testing {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

inline DatasetRecord MakeDataset(const std::string& name, const std::string& content) {
  return DatasetRecord{Sha256Hex(content), name, content};
}

inline JobRecord MakeJob(const std::string& eval_key, const std::string& options_json = "{\"seed\":1}") {
  JobRecord job;
  job.eval_key = eval_key;
  job.options_json = options_json;
  return job;
}

// Deterministic, distinct coefficient sets: callers generate sets the same way,
// so equal sets are bit-identical doubles.
inline Coefficients SetNumber(int i) {
  return {0.1 * i, 0.01 * i + 0.5, 0.003 * (i % 7), 0.001 * (i / 7)};
}

inline EvaluationRecord Eval(int phase, int i, double e) {
  return EvaluationRecord{phase, SetNumber(i), e};
}

// A second connection to the same file, as another process would have, to look
// at what is really on disk and to hold locks.
class RawConnection {
 public:
  explicit RawConnection(const std::string& path) {
    if (sqlite3_open(path.c_str(), &db_) != SQLITE_OK) ADD_FAILURE() << "raw open failed: " << sqlite3_errmsg(db_);
  }
  ~RawConnection() { sqlite3_close(db_); }
  int Exec(const std::string& sql) { return sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr); }
  std::string QueryText(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    std::string out = "<error>";
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW) {
      const unsigned char* text = sqlite3_column_text(st, 0);
      out = text ? reinterpret_cast<const char*>(text) : "<null>";
    }
    sqlite3_finalize(st);
    return out;
  }

 private:
  sqlite3* db_ = nullptr;
};

class JobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = ::testing::TempDir() + "wormdrag_store_" + info->name() + "_" + std::to_string(getpid()) + ".db";
    RemoveFiles();
    Reopen();
  }
  void TearDown() override {
    store_.reset();
    RemoveFiles();
  }
  void RemoveFiles() {
    for (const char* suffix : {"", "-wal", "-shm"}) std::remove((path_ + suffix).c_str());
  }
  void Reopen() {
    store_.reset();  // closes the previous connection first
    auto opened = JobStore::Open(path_);
    ASSERT_TRUE(opened.ok()) << opened.status().ToString();
    store_ = std::move(*opened);
  }
  int64_t CreateJob(const std::string& eval_key, const std::string& content1 = "k1 data",
                    const std::string& content2 = "k2 data") {
    auto id = store_->CreateJob(MakeJob(eval_key), {MakeDataset("k1.csv", content1), MakeDataset("k2.csv", content2)});
    EXPECT_TRUE(id.ok()) << id.status().ToString();
    return id.ok() ? *id : -1;
  }

  std::string path_;
  std::unique_ptr<JobStore> store_;
};

// ------------------------------------------------------------------ open

}  // namespace wormdrag::store_testing
