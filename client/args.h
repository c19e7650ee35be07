// A small command-line parser shared by the wormdrag commands: --name value,
// --name=value, boolean --flag, positionals; unknown options are errors.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace wormdrag::cli {

struct OptionSpec {
  std::string name;         // without dashes
  std::string value_name;   // "" for a boolean flag
  std::string help;
  std::string default_value;  // shown in --help; "" = none / required where the command says so
};

class Args {
 public:
  // Parses argv[first…]; `specs` lists the accepted options.
  static Result<Args> Parse(int argc, char** argv, int first, const std::vector<OptionSpec>& specs);
  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  std::string Get(const std::string& name, const std::string& fallback = "") const;
  Result<double> GetDouble(const std::string& name, double fallback) const;
  Result<long> GetInt(const std::string& name, long fallback) const;
  Result<std::string> Require(const std::string& name) const;
  const std::vector<std::string>& positionals() const { return positionals_; }

 private:
  std::map<std::string, std::string> values_;
  std::vector<std::string> positionals_;
};

// Usage text: "usage: wormdrag CMD SYNOPSIS\n\nDESCRIPTION\n\noptions:\n  --x V  help (default …)".
std::string Usage(const std::string& command, const std::string& synopsis, const std::string& description,
                  const std::vector<OptionSpec>& specs);

// Prints "wormdrag CMD: message" to stderr and returns the exit code for it (2 for
// bad input, 1 otherwise).
int Fail(const std::string& command, const Status& status);

// If argv[first…] holds --help or -h, prints `usage` to stdout and returns true.
bool PrintedHelp(int argc, char** argv, const std::string& usage, int first = 2);

// True when stderr is a terminal (progress bars only then).
bool StderrIsTerminal();

}  // namespace wormdrag::cli
