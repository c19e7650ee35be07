// Entry points of the wormdrag subcommands; each returns the process exit code.
#pragma once

namespace wormdrag::cli {

int RunSimulate(int argc, char** argv);
int RunGenerate(int argc, char** argv);

}  // namespace wormdrag::cli
