#include "core/common/flags.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "core/common/format.h"

namespace wormdrag::flags {
namespace {

constexpr size_t kHelpColumn = 28;

}  // namespace

std::vector<std::string> ArgList(int argc, char** argv) {
  return argc > 1 ? std::vector<std::string>(argv + 1, argv + argc) : std::vector<std::string>();
}

Result<Args> Args::Parse(const std::vector<std::string>& args, const std::vector<Option>& options, bool positionals) {
  Args a;
  std::map<std::string, const Option*> by_name;
  for (const auto& o : options) by_name[o.name] = &o;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
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
        a.values_[name].push_back("1");
        continue;
      }
      if (!inline_value) {
        if (i + 1 >= args.size())
          return Status::InvalidArgument("option --" + name + " needs a value " + it->second->value_name);
        value = args[++i];
      }
      a.values_[name].push_back(value);
    } else if (positionals) {
      a.positionals_.push_back(arg);
    } else {
      return Status::InvalidArgument("unexpected argument '" + arg + "' (see --help)");
    }
  }
  return a;
}

std::string Args::Get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second.back();
}

std::vector<std::string> Args::GetAll(const std::string& name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>() : it->second;
}

Result<double> Args::GetDouble(const std::string& name, double fallback) const {
  if (!Has(name)) return fallback;
  const std::string s = Get(name);
  double v = 0;
  if (!ToDouble(s, &v)) return Status::InvalidArgument("--" + name + ": not a number: '" + s + "'");
  return v;
}

Result<long> Args::GetInt(const std::string& name, long fallback) const {
  if (!Has(name)) return fallback;
  const std::string s = Get(name);
  long v = 0;
  if (!ToLong(s, &v)) return Status::InvalidArgument("--" + name + ": not a whole number: '" + s + "'");
  return v;
}

Result<long> Args::GetIntIn(const std::string& name, long fallback, long lo, long hi) const {
  if (!Has(name)) return fallback;
  long v = 0;
  const std::string s = Get(name);
  if (ToLong(s, &v) && v >= lo && v <= hi) return v;
  const std::string range = hi == std::numeric_limits<long>::max()
                                ? ">= " + std::to_string(lo)
                                : "from " + std::to_string(lo) + " to " + std::to_string(hi);
  return Status::InvalidArgument("--" + name + " must be a whole number " + range + ", not '" + s + "'");
}

Result<std::string> Args::Require(const std::string& name) const {
  const std::string s = Get(name);
  if (s.empty()) return Status::InvalidArgument("missing required option --" + name);
  return s;
}

std::string Usage(const std::string& program, const std::string& synopsis, const std::string& description,
                  const std::vector<Option>& options) {
  std::string s = "usage: " + program + " " + synopsis + "\n\n" + description + "\n";
  if (!options.empty()) s += "\noptions:\n";
  for (const auto& o : options) {
    std::string left = "  --" + o.name + (o.value_name.empty() ? "" : " " + o.value_name);
    if (left.size() < kHelpColumn)
      left.resize(kHelpColumn, ' ');
    else
      left += "\n" + std::string(kHelpColumn, ' ');
    std::string help = o.help;
    for (size_t nl = help.find('\n'); nl != std::string::npos; nl = help.find('\n', nl + 1 + kHelpColumn))
      help.insert(nl + 1, kHelpColumn, ' ');
    s += left + help;
    if (!o.default_value.empty()) s += " (default " + o.default_value + ")";
    s += "\n";
  }
  return s;
}

std::string FirstOption(const std::vector<std::string>& args, const std::vector<std::string>& names) {
  for (const auto& a : args)
    for (const auto& n : names)
      if (a == "--" + n || a.rfind("--" + n + "=", 0) == 0) return n;
  return "";
}

bool PrintedHelp(const std::vector<std::string>& args, const std::string& usage) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") {
      std::fputs(usage.c_str(), stdout);
      return true;
    }
  return false;
}

int Fail(const std::string& program, const Status& status) {
  std::fprintf(stderr, "%s: %s\n", program.c_str(), status.message().c_str());
  // A token of the wrong role is bad input like a wrong path: retrying cannot help.
  const Status::Code c = status.code();
  return c == Status::Code::kInvalidArgument || c == Status::Code::kNotFound || c == Status::Code::kPermissionDenied
             ? 2
             : 1;
}

std::optional<int> Parse(const std::vector<std::string>& args, const Spec& spec, Args* out) {
  if (PrintedHelp(args, Usage(spec))) return 0;
  auto a = Args::Parse(args, spec.options, spec.positionals);
  if (!a.ok()) {
    std::fprintf(stderr, "%s: %s\n", spec.program.c_str(), a.status().message().c_str());
    return 2;
  }
  *out = std::move(*a);
  return std::nullopt;
}

bool ToDouble(const std::string& s, double* out) {
  char* end = nullptr;
  errno = 0;
  *out = std::strtod(s.c_str(), &end);
  return !s.empty() && end && *end == '\0' && errno != ERANGE && std::isfinite(*out);
}

bool ToDoubles(const std::string& list, bool (*accept)(double), std::vector<double>* out, std::string* bad) {
  out->clear();
  for (const std::string& item : SplitList(list)) {
    double v = 0;
    if (!ToDouble(item, &v) || !accept(v)) {
      *bad = item;
      return false;
    }
    out->push_back(v);
  }
  return true;
}

bool ToLong(const std::string& s, long* out) {
  char* end = nullptr;
  errno = 0;
  *out = std::strtol(s.c_str(), &end, 10);
  return !s.empty() && end && *end == '\0' && errno != ERANGE;
}

}  // namespace wormdrag::flags
