// A minimal --name value / --name=value / --flag parser for the service binaries
// (which do not link the CLI library).
#pragma once

#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>

namespace wormdrag::flags {

// Blocks SIGTERM and SIGINT in the calling thread and every thread it starts later, for
// one sigwait thread to take them (returned: the set to wait on). Call it first in
// main, before gRPC or anything else starts a thread: threads inherit the mask.
inline sigset_t BlockTerminationSignals() {
  sigset_t sigs;
  sigemptyset(&sigs);
  sigaddset(&sigs, SIGTERM);
  sigaddset(&sigs, SIGINT);
  pthread_sigmask(SIG_BLOCK, &sigs, nullptr);
  return sigs;
}

// Prints `usage` to stdout if --help or -h is among the arguments, and says so.
inline bool PrintedHelp(int argc, char** argv, const char* usage) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(usage, stdout);
      return true;
    }
  return false;
}

struct Parsed {
  std::map<std::string, std::string> values;
  std::string error;
  bool Has(const std::string& k) const { return values.count(k) > 0; }
  std::string Get(const std::string& k, const std::string& d = "") const {
    auto it = values.find(k);
    return it == values.end() ? d : it->second;
  }
};

// `with_value`: options taking a value; `booleans`: flags.
inline Parsed Parse(int argc, char** argv, const std::set<std::string>& with_value,
                    const std::set<std::string>& booleans) {
  Parsed p;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a.rfind("--", 0) != 0) {
      p.error = "unexpected argument '" + a + "'";
      return p;
    }
    a = a.substr(2);
    std::string v;
    bool has_v = false;
    if (auto eq = a.find('='); eq != std::string::npos) {
      v = a.substr(eq + 1);
      a = a.substr(0, eq);
      has_v = true;
    }
    if (booleans.count(a)) {
      p.values[a] = has_v ? v : "true";
    } else if (with_value.count(a)) {
      if (!has_v) {
        if (i + 1 >= argc) {
          p.error = "--" + a + " needs a value";
          return p;
        }
        v = argv[++i];
      }
      p.values[a] = v;
    } else {
      p.error = "unknown option --" + a;
      return p;
    }
  }
  return p;
}

inline bool ToDouble(const std::string& s, double* out) {
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return !s.empty() && end && *end == '\0';
}
inline bool ToLong(const std::string& s, long* out) {
  char* end = nullptr;
  *out = std::strtol(s.c_str(), &end, 10);
  return !s.empty() && end && *end == '\0';
}

}  // namespace wormdrag::flags
