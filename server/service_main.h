// The start of both service mains (wormdrag-server, wormdrag-worker): termination
// signals blocked for one sigwait thread, the command line, the log format, the error
// exit. Header-only: the worker does not link the coordinator's library.
#pragma once

#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <spdlog/pattern_formatter.h>
#include <spdlog/spdlog.h>

#include "core/common/flags.h"
#include "core/common/json.h"

namespace wormdrag::service {

// The message of a log line as a JSON string: quoted and escaped, since messages quote
// their free-text fields (error="…", reason="…") and may hold any byte.
class JsonMessageFlag : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&, spdlog::memory_buf_t& dest) override {
    const std::string text = Dump(Json(std::string(msg.payload.data(), msg.payload.size())));
    dest.append(text.data(), text.data() + text.size());
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<JsonMessageFlag>(); }
};

// --log-json's format: one JSON object per line, {"ts", "level", "proc", "msg"}, UTC.
inline std::unique_ptr<spdlog::formatter> JsonLogFormatter(const std::string& program) {
  auto f = std::make_unique<spdlog::pattern_formatter>(spdlog::pattern_time_type::utc);
  f->add_flag<JsonMessageFlag>('*').set_pattern(R"({"ts":"%Y-%m-%dT%H:%M:%S.%fZ","level":"%l","proc":)" +
                                                Dump(Json(program)) + R"(,"msg":%*})");
  return f;
}

class ServiceMain {
 public:
  // Blocks SIGTERM and SIGINT in the calling thread and every thread it starts later, for
  // WaitForSignal to take them. Construct it first in main, before gRPC or anything else
  // starts a thread: threads inherit the mask.
  explicit ServiceMain(flags::Spec spec) : spec_(std::move(spec)) {
    sigemptyset(&signals_);
    sigaddset(&signals_, SIGTERM);
    sigaddset(&signals_, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals_, nullptr);
  }

  // Parses the command line (--help: exit code 0; a bad one: 2) and sets the log format:
  // one JSON object per line with --log-json (the spec must list it), else text.
  // nullopt when the process goes on.
  std::optional<int> Start(int argc, char** argv) {
    if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec_, &flags_)) return rc;
    if (flags_.Has("log-json"))
      spdlog::set_formatter(JsonLogFormatter(spec_.program));
    else
      spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ " + spec_.program + " %v");
    spdlog::flush_on(spdlog::level::info);
    return std::nullopt;
  }

  const flags::Args& flags() const { return flags_; }

  // Prints "PROGRAM: message" to stderr and returns the exit code of a process that
  // cannot start (2).
  int Die(const std::string& message) const {
    std::fprintf(stderr, "%s: %s\n", spec_.program.c_str(), message.c_str());
    return 2;
  }

  // Waits for SIGTERM or SIGINT and returns which; "SIGTERM" or "SIGINT" in *name.
  int WaitForSignal(const char** name) const {
    int sig = 0;
    sigwait(&signals_, &sig);
    *name = sig == SIGTERM ? "SIGTERM" : "SIGINT";
    return sig;
  }

 private:
  flags::Spec spec_;
  sigset_t signals_;
  flags::Args flags_;
};

}  // namespace wormdrag::service
