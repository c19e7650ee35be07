#include "core/store/writer_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>

#include "core/store/sqlite_handle.h"

namespace wormdrag {

namespace {

std::string ReadAll(int fd) {
  std::string s;
  char buf[512];
  ssize_t n;
  lseek(fd, 0, SEEK_SET);
  while ((n = read(fd, buf, sizeof buf)) > 0 && s.size() < 4096) s.append(buf, static_cast<size_t>(n));
  while (!s.empty() && (s.back() == '\n' || s.back() == '\0')) s.pop_back();
  return s;
}

}  // namespace

Result<std::unique_ptr<WriterLock>> WriterLock::Acquire(const std::string& db_path) {
  const std::string path = db_path + ".lock";
  const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0)
    return Status::FailedPrecondition(path + ": cannot open the database's lock file: " + std::strerror(errno));
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    std::string holder = err == EWOULDBLOCK ? ReadAll(fd) : "";
    close(fd);
    if (err != EWOULDBLOCK)
      return Status::FailedPrecondition(path + ": cannot lock the database's lock file: " + std::strerror(err));
    if (holder.empty()) holder = "a process that has not written its identity yet";
    return Status::FailedPrecondition(db_path + " is in use by another coordinator (" + holder + "; lock file " + path +
                                      "): stop it first, or give this one another --db");
  }
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  char started[32] = "";
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::strftime(started, sizeof started, "%Y-%m-%dT%H:%M:%SZ", &tm);
  const std::string who = "pid " + std::to_string(getpid()) + " on host " + host + ", started " + started + "\n";
  if (ftruncate(fd, 0) != 0 || pwrite(fd, who.data(), who.size(), 0) != static_cast<ssize_t>(who.size())) {
    const int err = errno;
    close(fd);
    return Status::FailedPrecondition(path + ": cannot write the lock file: " + std::strerror(err));
  }
  return std::unique_ptr<WriterLock>(new WriterLock(fd, path));
}

WriterLock::~WriterLock() {
  // The file stays (removing it would race with a coordinator taking it); closing
  // releases the lock.
  close(fd_);
}

Status CheckDatabaseIntegrity(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec) || std::filesystem::file_size(path, ec) == 0) return Status::Ok();
  auto db = sqlite::Database::Open(path);
  if (!db.ok()) return db.status();
  WORMDRAG_RETURN_IF_ERROR(db->Exec("PRAGMA busy_timeout = 5000", "set busy_timeout"));
  const std::string advice = "; restore it from a backup (or move it aside to start with an empty store)";
  auto st = sqlite::Statement::Prepare(*db, "PRAGMA quick_check(5)", "quick_check");
  if (!st.ok())
    return Status::FailedPrecondition(path + ": the database is damaged or not a database: " + st.status().message() +
                                      advice);
  std::string findings;
  for (;;) {
    auto row = st->Step();
    if (!row.ok())
      return Status::FailedPrecondition(
          path + ": the database is damaged: PRAGMA quick_check failed: " + row.status().message() + advice);
    if (!*row) break;
    std::string line = st->ColumnText(0);
    if (line == "ok") return Status::Ok();
    for (char& c : line)
      if (c == '\n') c = ' ';
    findings += (findings.empty() ? "" : "; ") + line;
  }
  return Status::FailedPrecondition(path + ": the database is damaged: PRAGMA quick_check: " + findings + advice);
}

}  // namespace wormdrag
