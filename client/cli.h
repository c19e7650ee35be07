// What every wormdrag command shares besides the flag library: its names in this
// namespace, the error exit and the terminal test for progress bars.
#pragma once

#include <unistd.h>

#include <string>
#include <vector>

#include "core/common/flags.h"
#include "core/common/status.h"

namespace wormdrag::cli {

using flags::Args;
using flags::Option;
using flags::PrintedHelp;
using flags::Usage;

// Prints "wormdrag COMMAND: message" to stderr and returns the exit code for it (2 for
// bad input, 1 otherwise).
inline int Fail(const std::string& command, const Status& status) {
  return flags::Fail("wormdrag " + command, status);
}

// True when stderr is a terminal (progress bars only then).
inline bool StderrIsTerminal() {
  return ::isatty(2) == 1;
}

}  // namespace wormdrag::cli
