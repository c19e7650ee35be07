// wormdrag: friction of C. elegans from video of its motion.
#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include "client/commands.h"

namespace {

struct Command {
  const char* name;
  int (*run)(const std::vector<std::string>&);
  const char* summary;
};

const Command kCommands[] = {
    {"simulate", wormdrag::cli::RunSimulate, "simulate the body model driven by a recording's joint angles"},
    {"generate", wormdrag::cli::RunGenerate, "write a synthetic recording from the paper's joint-angle pattern"},
    {"estimate", wormdrag::cli::RunEstimate, "estimate the friction coefficients from two recordings (embedded)"},
    {"jobs", wormdrag::cli::RunJobs, "list past jobs or show one"},
    {"results", wormdrag::cli::RunResults, "print the evaluated sets of a job, best first (text, csv, json)"},
    {"verify", wormdrag::cli::RunVerify, "the paper's verification: recover preset coefficients from simulations"},
    {"submit", wormdrag::cli::RunSubmit, "submit an estimation job to a wormdrag-server (or run it here)"},
    {"watch", wormdrag::cli::RunWatch, "follow a job: phase, tasks, workers, rate, ETA, best E"},
    {"cancel", wormdrag::cli::RunCancel, "cancel a queued or running job"},
    {"diagnose", wormdrag::cli::RunDiagnose,
     "where the remaining path error lies and which unmodelled effect causes it"},
    {"synth", wormdrag::cli::RunSynth, "write a synthetic recording with an injected effect and its truth"},
    {"report", wormdrag::cli::RunReport,
     "a self-contained HTML report of a stored job (paths, E slices, identifiability)"},
    {"analyze", wormdrag::cli::RunAnalyze,
     "the paper's section 4: friction forces, trajectories, group comparison (t-test)"},
    {"track", wormdrag::cli::RunTrack, "track the worm's midline in a video, TIFF stack or image folder"},
    {"import", wormdrag::cli::RunImport, "convert a WT2 .mat, WCON or .npy kymogram to kinematics"},
    {"export", wormdrag::cli::RunExport, "write kinematics as WCON"},
};

void PrintHelp() {
  std::printf(
      "usage: wormdrag COMMAND [options]   (wormdrag COMMAND --help for each)\n\n"
      "Estimates the friction a C. elegans worm feels from the motion of its body\n"
      "(Soh, Suzuki & Tsuji). Lengths in mm, time in s, forces in uN.\n\ncommands:\n");
  for (const auto& c : kCommands) std::printf("  %-12s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> words = wormdrag::flags::ArgList(argc, argv);
  if (words.empty() || words[0] == "--help" || words[0] == "-h" || words[0] == "help") {
    PrintHelp();
    return words.empty() ? 2 : 0;
  }
  const std::vector<std::string> rest(words.begin() + 1, words.end());
  for (const auto& c : kCommands)
    if (words[0] == c.name) {
      // Commands report bad input as a Status (exit 2); an exception reaching here is a
      // bug or exhausted memory, and ends the command with a message instead of abort().
      try {
        return c.run(rest);
      } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "wormdrag %s: out of memory\n", c.name);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "wormdrag %s: internal error: %s\n", c.name, e.what());
      } catch (...) { std::fprintf(stderr, "wormdrag %s: internal error\n", c.name); }
      return 1;
    }
  std::fprintf(stderr, "wormdrag: unknown command '%s' (see wormdrag --help)\n", words[0].c_str());
  return 2;
}
