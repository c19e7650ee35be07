// The one command-line parser of every wormdrag binary and benchmark: a table of
// options, from which --help is generated, and `--name value`, `--name=value`, boolean
// `--flag` and positional arguments. An option not in the table is an error.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/common/status.h"

namespace wormdrag::flags {

struct Option {
  std::string name;           // without dashes
  std::string value_name;     // "" for a boolean flag
  std::string help;           // may span lines: each '\n' continues under the help column
  std::string default_value;  // shown in --help; "" = none / required where the program says so
};

// A program's (or a subcommand's) command line: what --help prints and what Parse accepts.
struct Spec {
  std::string program;      // "wormdrag estimate", "wormdrag-server": usage line and error prefix
  std::string synopsis;     // the rest of the usage line
  std::string description;  // printed after the usage line
  std::vector<Option> options;
  bool positionals = true;  // false: an argument that is not an option is an error
};

// The arguments after the program name, argv[1…argc): what every main hands on.
std::vector<std::string> ArgList(int argc, char** argv);

class Args {
 public:
  // Parses `args`; `options` lists the accepted options. With `positionals` false an
  // argument that is no option (nor an option's value) is an error.
  static Result<Args> Parse(const std::vector<std::string>& args, const std::vector<Option>& options,
                            bool positionals = true);
  bool Has(const std::string& name) const { return values_.count(name) > 0; }
  // The last value given (an option given twice takes its second value).
  std::string Get(const std::string& name, const std::string& fallback = "") const;
  // Every value given, in order (options that may repeat).
  std::vector<std::string> GetAll(const std::string& name) const;
  Result<double> GetDouble(const std::string& name, double fallback) const;
  Result<long> GetInt(const std::string& name, long fallback) const;
  // A whole number in [lo, hi] (`fallback`, unchecked, when the option is absent):
  // "--NAME must be a whole number from LO to HI, not 'V'" (">= LO" when hi is
  // LONG_MAX) otherwise, so every command words its range errors alike.
  Result<long> GetIntIn(const std::string& name, long fallback, long lo, long hi) const;
  Result<std::string> Require(const std::string& name) const;
  const std::vector<std::string>& positionals() const { return positionals_; }

 private:
  std::map<std::string, std::vector<std::string>> values_;
  std::vector<std::string> positionals_;
};

// Usage text: "usage: PROGRAM SYNOPSIS\n\nDESCRIPTION\n\noptions:\n  --x V  help (default …)".
std::string Usage(const std::string& program, const std::string& synopsis, const std::string& description,
                  const std::vector<Option>& options);
inline std::string Usage(const Spec& spec) {
  return Usage(spec.program, spec.synopsis, spec.description, spec.options);
}

// The first of `names` that `args` give as an option (--name or --name=…), "" if none:
// for a program whose option table depends on an option (`wormdrag jobs --server`).
std::string FirstOption(const std::vector<std::string>& args, const std::vector<std::string>& names);

// If `args` holds --help or -h, prints `usage` to stdout and returns true.
bool PrintedHelp(const std::vector<std::string>& args, const std::string& usage);

// Prints "PROGRAM: message" to stderr and returns the exit code for it: 2 for bad input
// (invalid argument, file not found, a credential of the wrong role), 1 otherwise.
int Fail(const std::string& program, const Status& status);

// The whole of a main's command-line handling: with --help or -h prints the usage to
// stdout and returns 0; on an unknown option, a missing value or (when the spec takes
// none) a positional prints "PROGRAM: error (see --help)" to stderr and returns 2; else
// fills *out and returns nullopt.
std::optional<int> Parse(const std::vector<std::string>& args, const Spec& spec, Args* out);

// Whole-string number conversions: false on trailing text, empty input, a value out of
// the type's range (an overflow, or for ToDouble an underflow), and for ToDouble on
// inf or nan, which no option of these programs means.
bool ToDouble(const std::string& s, double* out);
bool ToLong(const std::string& s, long* out);
// Each comma-separated item of `list` through ToDouble, kept where `accept` holds for it;
// false at the first item that is no number or not accepted, with *bad set to that item.
bool ToDoubles(const std::string& list, bool (*accept)(double), std::vector<double>* out, std::string* bad);

}  // namespace wormdrag::flags
