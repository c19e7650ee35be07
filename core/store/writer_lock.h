// One writer per database file: the coordinator holds an exclusive lock on a file
// beside the database (`<db>.lock`, flock) for as long as it runs, and writes who
// holds it (pid, host, start time) into that file. A second coordinator started on
// the same database is refused with the holder's identity instead of running two
// schedulers over one set of jobs. The kernel drops the lock when the holder dies
// however it dies, so a crash never leaves a stale lock behind.
//
// Readers (the CLI's local commands, tests) do not take it: SQLite's own locking
// keeps them consistent with the one writer.
#pragma once

#include <memory>
#include <string>

#include "core/common/status.h"

namespace wormdrag {

class WriterLock {
 public:
  // Takes the lock of `db_path`, or FAILED_PRECONDITION naming the holder.
  static Result<std::unique_ptr<WriterLock>> Acquire(const std::string& db_path);
  ~WriterLock();
  WriterLock(const WriterLock&) = delete;
  WriterLock& operator=(const WriterLock&) = delete;

  const std::string& path() const { return path_; }

 private:
  WriterLock(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  int fd_;
  std::string path_;
};

// PRAGMA quick_check of the database at `path` (structure of every b-tree page, not
// index contents): OK for a sound or absent file, FAILED_PRECONDITION naming the file
// and SQLite's first findings when it is damaged or not a database.
Status CheckDatabaseIntegrity(const std::string& path);

}  // namespace wormdrag
