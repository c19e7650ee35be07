// wormdrag import (tracker files → kinematics CSV) and wormdrag export --wcon.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "client/args.h"
#include "client/commands.h"
#include "core/filter/butterworth.h"
#include "core/io/gaps.h"
#include "core/io/kinematics.h"
#include "core/io/kymogram.h"
#include "core/io/wcon.h"
#include "core/io/wt2_mat.h"

namespace wormdrag::cli {
namespace {

std::string FormatOf(const std::string& path, const std::string& given) {
  if (!given.empty()) return given;
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".mat") return "mat";
  if (ext == ".wcon" || ext == ".json") return "wcon";
  if (ext == ".npy") return "npy";
  if (ext == ".csv") return "csv";
  return "";
}

}  // namespace

int RunImport(int argc, char** argv) {
  const std::vector<OptionSpec> specs = {
      {"out", "K.csv", "kinematics file to write (docs/conventions.md §6)", ""},
      {"format", "F", "mat (Worm Tracker 2 features), wcon, npy (joint-angle kymogram), csv (kinematics)",
       "from the extension"},
      {"fps", "F", "frame rate: required for npy; overrides the file's for wcon", ""},
      {"id", "ID", "WCON worm id to import", "the first"},
      {"flip-sign", "", "npy: negate the angles (the other polarity convention)", ""},
      {"frames", "FIRST:LAST", "keep only frames FIRST … LAST (0-based, inclusive; time re-zeroed at FIRST)", "all"},
      {"interpolate-gaps", "N", "fill runs of at most N missing frames (shape and pose interpolated)", "0 = keep missing"},
      {"lowpass", "HZ", "filter the joint angles: 2nd-order Butterworth at HZ (the paper: 5)", "off"},
      {"causal", "", "with --lowpass: forward only instead of zero phase", ""},
  };
  const std::string usage = Usage(
      "import", "FILE --out K.csv [options]",
      "Converts a tracker's output to a kinematics file: Schafer-lab Worm Tracker 2 features\n"
      ".mat (worm.posture.skeleton, µm), WCON (JSON), or a NumPy joint-angle kymogram (shape\n"
      "only: built with unit body length, head at the origin). Missing and dropped frames are\n"
      "kept as missing unless --interpolate-gaps fills the short ones. --frames cuts a segment\n"
      "(any format, also a kinematics .csv), before gaps are filled and the filter runs.",
      specs);
  if (PrintedHelp(argc, argv, usage)) return 0;
  auto args = Args::Parse(argc, argv, 2, specs);
  if (!args.ok()) return Fail("import", args.status());
  if (args->positionals().size() != 1)
    return Fail("import", Status::InvalidArgument("expected one FILE to import; see --help"));
  const std::string in = args->positionals()[0];
  auto out = args->Require("out");
  if (!out.ok()) return Fail("import", out.status());
  auto fps = args->GetDouble("fps", 0);
  auto gaps = args->GetInt("interpolate-gaps", 0);
  auto lowpass = args->GetDouble("lowpass", 0);
  for (const Status& s : {fps.status(), gaps.status(), lowpass.status()})
    if (!s.ok()) return Fail("import", s);
  if (*fps < 0 || *gaps < 0 || *lowpass < 0)
    return Fail("import", Status::InvalidArgument("--fps, --interpolate-gaps and --lowpass must not be negative"));

  const std::string format = FormatOf(in, args->Get("format"));
  Result<Kinematics> k = Status::InvalidArgument(
      in + ": unknown format; give --format mat, wcon or npy");
  if (format == "mat") {
    auto r = ReadWt2Features(in);
    if (!r.ok()) return Fail("import", r.status());
    k = std::move(r->kinematics);
    if (*fps > 0) {
      k->fps = *fps;
      for (size_t i = 0; i < k->frames.size(); ++i) k->frames[i].t = i / *fps;
      k->metadata["fps"] = std::to_string(*fps);
    }
  } else if (format == "wcon") {
    k = ReadWcon(in, {args->Get("id"), *fps});
  } else if (format == "csv") {
    k = ReadKinematics(in);
  } else if (format == "npy") {
    auto a = ReadNpy(in);
    if (!a.ok()) return Fail("import", a.status());
    k = KymogramToKinematics(*a, {*fps, args->Has("flip-sign")}, in);
  }
  if (!k.ok()) return Fail("import", k.status());
  if (args->Has("frames")) {
    const std::string spec = args->Get("frames");
    const size_t colon = spec.find(':');
    char* e1 = nullptr;
    char* e2 = nullptr;
    long first = -1, last = -1;
    if (colon != std::string::npos) {
      const std::string a = spec.substr(0, colon), b = spec.substr(colon + 1);
      first = std::strtol(a.c_str(), &e1, 10);
      last = std::strtol(b.c_str(), &e2, 10);
      if (a.empty() || b.empty() || *e1 != '\0' || *e2 != '\0') first = last = -1;
    }
    const long n = static_cast<long>(k->frames.size());
    if (first < 0 || last < first)
      return Fail("import", Status::InvalidArgument("--frames must be FIRST:LAST with 0 <= FIRST <= LAST, got '" + spec + "'"));
    if (last >= n)
      return Fail("import", Status::InvalidArgument("--frames " + spec + ": " + in + " has only " + std::to_string(n) +
                                                    " frames (0 … " + std::to_string(n - 1) + ")"));
    std::vector<Frame> kept(k->frames.begin() + first, k->frames.begin() + last + 1);
    const double t0 = kept.front().t;
    for (auto& f : kept) f.t -= t0;
    k->frames = std::move(kept);
    k->metadata["frames"] = std::to_string(first) + ":" + std::to_string(last) + " of " +
                            std::filesystem::path(in).filename().string();
    bool any = false;
    for (const auto& f : k->frames) any = any || f.valid;
    if (!any) return Fail("import", Status::InvalidArgument("--frames " + spec + ": every frame in the range is missing"));
  }
  const int missing_before = static_cast<int>(k->frames.size()) - k->NumValid();
  const int filled = InterpolateShortGaps(*k, static_cast<int>(*gaps));
  if (*lowpass > 0) {
    AngleFilterOptions fo;
    fo.cutoff_hz = *lowpass;
    fo.zero_phase = !args->Has("causal");
    auto f = FilterJointAngles(*k, fo);
    if (!f.ok()) return Fail("import", f.status());
    k = std::move(f);
  }
  Status st = WriteKinematics(*k, *out);
  if (!st.ok()) return Fail("import", st);
  std::fprintf(stderr, "%s: %zu frames at %.5g fps, %d missing%s, body length %.4g mm\n", in.c_str(),
               k->frames.size(), k->fps, missing_before,
               filled ? (", " + std::to_string(filled) + " interpolated").c_str() : "", k->BodyLength());
  return 0;
}

int RunExport(int argc, char** argv) {
  const std::vector<OptionSpec> specs = {
      {"wcon", "OUT.wcon", "write the recording as WCON (JSON; units s and mm; missing frames as null)", ""},
  };
  const std::string usage = Usage("export", "K.csv --wcon OUT.wcon",
                                  "Writes a kinematics file in another tracker format.", specs);
  if (PrintedHelp(argc, argv, usage)) return 0;
  auto args = Args::Parse(argc, argv, 2, specs);
  if (!args.ok()) return Fail("export", args.status());
  if (args->positionals().size() != 1)
    return Fail("export", Status::InvalidArgument("expected one kinematics file K.csv; see --help"));
  auto out = args->Require("wcon");
  if (!out.ok()) return Fail("export", out.status());
  auto k = ReadKinematics(args->positionals()[0]);
  if (!k.ok()) return Fail("export", k.status());
  Status st = WriteWcon(*k, *out);
  if (!st.ok()) return Fail("export", st);
  return 0;
}

}  // namespace wormdrag::cli
