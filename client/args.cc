#include "client/args.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <unistd.h>

namespace wormdrag::cli {

Result<Args> Args::Parse(int argc, char** argv, int first, const std::vector<OptionSpec>& specs) {
  Args a;
  std::map<std::string, const OptionSpec*> by_name;
  for (const auto& s : specs) by_name[s.name] = &s;
  for (int i = first; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg.size() > 2 && arg[0] == '-' && arg[1] == '-') {
      std::string name = arg.substr(2), value;
      bool inline_value = false;
      if (auto eq = name.find('='); eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        inline_value = true;
      }
      auto it = by_name.find(name);
      if (it == by_name.end()) return Status::InvalidArgument("unknown option --" + name + " (see --help)");
      if (it->second->value_name.empty()) {
        if (inline_value) return Status::InvalidArgument("option --" + name + " takes no value");
        a.values_[name] = "1";
        continue;
      }
      if (!inline_value) {
        if (i + 1 >= argc) return Status::InvalidArgument("option --" + name + " needs a value " + it->second->value_name);
        value = argv[++i];
      }
      a.values_[name] = value;
    } else {
      a.positionals_.push_back(arg);
    }
  }
  return a;
}

std::string Args::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

Result<double> Args::GetDouble(const std::string& name, double fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    return Status::InvalidArgument("--" + name + ": not a number: '" + it->second + "'");
  return v;
}

Result<long> Args::GetInt(const std::string& name, long fallback) const {
  auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0' || errno == ERANGE)
    return Status::InvalidArgument("--" + name + ": not a whole number: '" + it->second + "'");
  return v;
}

Result<std::string> Args::Require(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end() || it->second.empty()) return Status::InvalidArgument("missing required option --" + name);
  return it->second;
}

std::string Usage(const std::string& command, const std::string& synopsis, const std::string& description,
                  const std::vector<OptionSpec>& specs) {
  std::string s = "usage: wormdrag " + command + " " + synopsis + "\n\n" + description + "\n";
  if (!specs.empty()) s += "\noptions:\n";
  for (const auto& o : specs) {
    std::string left = "  --" + o.name + (o.value_name.empty() ? "" : " " + o.value_name);
    if (left.size() < 28) left.resize(28, ' ');
    else left += "\n" + std::string(28, ' ');
    s += left + o.help;
    if (!o.default_value.empty()) s += " (default " + o.default_value + ")";
    s += "\n";
  }
  return s;
}

int Fail(const std::string& command, const Status& status) {
  std::fprintf(stderr, "wormdrag %s: %s\n", command.c_str(), status.message().c_str());
  return status.code() == Status::Code::kInvalidArgument || status.code() == Status::Code::kNotFound ? 2 : 1;
}

bool PrintedHelp(int argc, char** argv, const std::string& usage, int first) {
  for (int i = first; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::fputs(usage.c_str(), stdout);
      return true;
    }
  return false;
}

bool StderrIsTerminal() { return ::isatty(2) == 1; }

}  // namespace wormdrag::cli
