// A minimal --name value / --name=value / --flag parser for the service binaries
// (which do not link the CLI library).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <string>

namespace wormdrag::flags {

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
