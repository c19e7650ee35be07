// Runs the built wormdrag binary as a user would and captures what it prints.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace wormdrag::testing {

struct Outcome {
  int code;         // exit code, -1 if it did not exit normally
  std::string out;  // stdout and stderr
};

// Runs a shell command line.
inline Outcome RunCommand(const std::string& command_line) {
  FILE* p = popen((command_line + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

inline Outcome RunWormdrag(const std::string& args) {
  return RunCommand(std::string(WORMDRAG_CLI) + " " + args);
}

}  // namespace wormdrag::testing
