// The service subcommands of the wormdrag CLI (client/cmd_remote.cc) behind a
// minimal main, so the integration tests run them as a real process before (and
// independently of) their wiring into client/main.cc.
#include <cstdio>
#include <cstring>

#include "client/commands.h"

int main(int argc, char** argv) {
  using namespace wormdrag::cli;
  if (argc < 2) {
    std::fprintf(stderr, "usage: wormdrag-svc-cli submit|watch|cancel|jobs|results ...\n");
    return 2;
  }
  const char* c = argv[1];
  if (!std::strcmp(c, "submit")) return RunSubmit(argc, argv);
  if (!std::strcmp(c, "watch")) return RunWatch(argc, argv);
  if (!std::strcmp(c, "cancel")) return RunCancel(argc, argv);
  if (!std::strcmp(c, "jobs")) return RunJobsRemote(argc, argv);
  if (!std::strcmp(c, "results")) return RunResultsRemote(argc, argv);
  std::fprintf(stderr, "wormdrag-svc-cli: unknown command '%s'\n", c);
  return 2;
}
