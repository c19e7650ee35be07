// wormdrag track: runs the wormdrag-track executable that is installed beside this one
// (client/track/main.cc has the command). Only that executable links OpenCV, so the other
// commands start without loading it.
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "client/commands.h"

namespace wormdrag::cli {
namespace {

// The directory of the running binary, with a trailing '/'. /proc/self/exe resolves
// symlinks, so a wormdrag linked into PATH still finds the helper beside the real file.
std::string SelfDirectory() {
  char buf[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return "";
  const std::string self(buf, static_cast<size_t>(n));
  return self.substr(0, self.rfind('/') + 1);
}

}  // namespace

int RunTrack(const std::vector<std::string>& cmdline) {
  const std::string dir = SelfDirectory();
  if (dir.empty()) {
    std::fprintf(stderr, "wormdrag track: cannot find this binary's directory (/proc/self/exe: %s)\n",
                 std::strerror(errno));
    return 2;
  }
  const std::string helper = dir + "wormdrag-track";
  // The helper gets `track …` as this process got it, so it parses the arguments as we would.
  std::vector<std::string> words = {helper, "track"};
  words.insert(words.end(), cmdline.begin(), cmdline.end());
  std::vector<char*> args;
  for (auto& w : words) args.push_back(w.data());
  args.push_back(nullptr);
  std::fflush(nullptr);
  ::execv(helper.c_str(), args.data());
  std::fprintf(stderr,
               "wormdrag track: cannot run %s: %s (the video tracker is a separate executable, "
               "installed beside wormdrag)\n",
               helper.c_str(), std::strerror(errno));
  return 2;
}

}  // namespace wormdrag::cli
