// `wormdrag report` and `wormdrag analyze` (client/cmd_report.cc) behind a minimal
// main, so their tests run them as a real process before (and independently of)
// their wiring into client/main.cc.
#include <cstdio>
#include <cstring>

#include "client/commands.h"

int main(int argc, char** argv) {
  using namespace wormdrag::cli;
  if (argc >= 2 && !std::strcmp(argv[1], "report")) return RunReport(argc, argv);
  if (argc >= 2 && !std::strcmp(argv[1], "analyze")) return RunAnalyze(argc, argv);
  if (argc >= 2 && !std::strcmp(argv[1], "estimate")) return RunEstimate(argc, argv);
  if (argc >= 2 && !std::strcmp(argv[1], "import")) return RunImport(argc, argv);
  std::fprintf(stderr, "usage: wormdrag-report-cli report|analyze|estimate|import ...\n");
  return 2;
}
