// wormdrag import (tracker files → kinematics CSV) and wormdrag export --wcon.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "client/cli.h"
#include "client/commands.h"
#include "core/filter/butterworth.h"
#include "core/io/celest.h"
#include "core/io/gaps.h"
#include "core/io/kinematics.h"
#include "core/io/kymogram.h"
#include "core/io/pose_csv.h"
#include "core/io/tierpsy.h"
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
  if (ext == ".hdf5" || ext == ".h5") return "tierpsy";
  if (ext == ".csv") {
    // A kinematics file starts with '# key: value' metadata or its t,x0,y0,… header.
    std::ifstream in(path);
    std::string first;
    std::getline(in, first);
    return LooksLikePoseCsv(first) ? "posecsv" : "csv";
  }
  if (ext == ".txt" && std::filesystem::path(path).filename().string().rfind("wormSegm_", 0) == 0) return "celest";
  return "";
}

// One worm of a CeleST segmentation, calibrated from --fps/--mm-per-px or fileDB.xml.
Result<CelestImport> ImportCelest(const std::string& in, const Args& args, double fps, double mm_per_px) {
  auto worm = args.GetInt("worm", 0);
  if (!worm.ok()) return worm.status();
  if (!args.Has("worm"))
    return Status::InvalidArgument(in + ": a CeleST file holds several worms; choose one with --worm N");
  if (*worm < 0 || *worm > 1000000)
    return Status::InvalidArgument("--worm " + args.Get("worm") + ": not a worm number");
  auto cal = ResolveCelestCalibration(in, args.Get("filedb"), fps, mm_per_px);
  if (!cal.ok()) return cal.status();
  CelestOptions opt;
  opt.worm = static_cast<int>(*worm);
  opt.calibration = *cal;
  return ReadCelest(in, opt);
}

// One worm of a Tierpsy featuresN / skeletons file (or WormPose's conversion).
Result<TierpsyImport> ImportTierpsy(const std::string& in, const Args& args, double fps, double um_per_px) {
  TierpsyOptions opt;
  if (args.Has("worm")) {
    auto worm = args.GetInt("worm", 0);
    if (!worm.ok()) return worm.status();
    if (*worm < 0) return Status::InvalidArgument("--worm " + args.Get("worm") + ": not a worm_index_joined");
    opt.worm = *worm;
  }
  opt.fps = fps;
  opt.um_per_px = um_per_px;
  opt.stage_file = args.Get("stage");
  opt.use_stage = !args.Has("no-stage");
  return ReadTierpsy(in, opt);
}

Result<PoseCsvImport> ImportPoseCsv(const std::string& in, const Args& args, double fps, double um_per_px) {
  PoseCsvOptions opt;
  auto p = args.GetDouble("min-likelihood", opt.min_likelihood);
  if (!p.ok()) return p.status();
  if (!(*p >= 0 && *p <= 1)) return Status::InvalidArgument("--min-likelihood must be within 0 … 1");
  opt.min_likelihood = *p;
  opt.fps = fps;
  opt.um_per_px = um_per_px;
  opt.individual = args.Get("id");
  return ReadPoseCsv(in, opt);
}

// One recording read in its format, and the line that describes the import (or empty).
struct Imported {
  Kinematics kinematics;
  std::string summary;
};

Result<Imported> ReadInFormat(const std::string& in, const Args& args, double fps, double scale_um) {
  const std::string format = FormatOf(in, args.Get("format"));
  Imported out;
  if (format == "mat") {
    auto r = ReadWt2Features(in);
    if (!r.ok()) return r.status();
    out.kinematics = std::move(r->kinematics);
    Kinematics& k = out.kinematics;
    if (fps > 0) {
      k.fps = fps;
      for (size_t i = 0; i < k.frames.size(); ++i) k.frames[i].t = i / fps;
      k.metadata["fps"] = std::to_string(fps);
    }
    return out;
  }
  Result<Kinematics> k = Status::InvalidArgument(
      in + ": unknown format; give --format mat, wcon, npy, csv, celest, tierpsy or posecsv");
  if (format == "wcon") {
    k = ReadWcon(in, {args.Get("id"), fps});
  } else if (format == "csv") {
    k = ReadKinematics(in);
  } else if (format == "npy") {
    auto a = ReadNpy(in);
    if (!a.ok()) return a.status();
    k = KymogramToKinematics(*a, {fps, args.Has("flip-sign")}, in);
  } else if (format == "celest") {
    auto r = ImportCelest(in, args, fps, scale_um / 1000);
    if (!r.ok()) return r.status();
    out.summary = in + " worm " + args.Get("worm") + ": calibration " + r->kinematics.metadata["calibration"] + "; " +
                  r->summary.Report();
    k = std::move(r->kinematics);
  } else if (format == "tierpsy") {
    auto r = ImportTierpsy(in, args, fps, scale_um);
    if (!r.ok()) return r.status();
    out.summary = in + ": " + r->summary.Report();
    k = std::move(r->kinematics);
  } else if (format == "posecsv") {
    auto r = ImportPoseCsv(in, args, fps, scale_um);
    if (!r.ok()) return r.status();
    out.summary = in + ": " + r->kinematics.metadata["import"];
    k = std::move(r->kinematics);
  }
  if (!k.ok()) return k.status();
  out.kinematics = std::move(*k);
  return out;
}

// --frames FIRST:LAST: keeps that segment of `in`'s frames, time re-zeroed at FIRST.
Status CutFrames(const std::string& spec, const std::string& in, Kinematics* k) {
  const size_t colon = spec.find(':');
  long first = -1, last = -1;
  if (colon == std::string::npos || !flags::ToLong(spec.substr(0, colon), &first) ||
      !flags::ToLong(spec.substr(colon + 1), &last))
    first = last = -1;
  const long n = static_cast<long>(k->frames.size());
  if (first < 0 || last < first)
    return Status::InvalidArgument("--frames must be FIRST:LAST with 0 <= FIRST <= LAST, got '" + spec + "'");
  if (last >= n)
    return Status::InvalidArgument("--frames " + spec + ": " + in + " has only " + std::to_string(n) + " frames (0 … " +
                                   std::to_string(n - 1) + ")");
  std::vector<Frame> kept(k->frames.begin() + first, k->frames.begin() + last + 1);
  const double t0 = kept.front().t;
  for (auto& f : kept) f.t -= t0;
  k->frames = std::move(kept);
  k->metadata["frames"] = std::to_string(first) + ":" + std::to_string(last) + " of " +
                          std::filesystem::path(in).filename().string();
  for (const auto& f : k->frames)
    if (f.valid) return Status::Ok();
  return Status::InvalidArgument("--frames " + spec + ": every frame in the range is missing");
}

}  // namespace

int RunImport(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"out", "K.csv", "kinematics file to write (docs/conventions.md §6)", ""},
      {"format", "F",
       "mat (Worm Tracker 2 features), wcon, npy (joint-angle kymogram), csv (kinematics), celest (CeleST "
       "wormSegm_*.txt), tierpsy (*_featuresN.hdf5, *_skeletons.hdf5), posecsv (DeepLabCut, SLEAP or x0,y0,… CSV)",
       "from the name; .csv: posecsv by its header"},
      {"fps", "F", "frame rate: required for npy and posecsv; overrides the file's for wcon, celest and tierpsy", ""},
      {"id", "ID", "wcon: worm id; posecsv: multi-animal DeepLabCut individual or SLEAP track", "the only one / first"},
      {"worm", "N", "celest: the worm to import (1-based, as in the file), required; tierpsy: its worm_index_joined",
       "tierpsy: the only worm"},
      {"filedb", "XML", "celest: CeleST fileDB.xml with the sample's fps and mm_per_pixel", "fileDB.xml beside FILE"},
      {"mm-per-px", "S", "image scale in mm per pixel: celest (overrides fileDB.xml), posecsv, tierpsy in pixels", ""},
      {"um-per-px", "S", "the same in µm per pixel (give one of the two); required for posecsv", ""},
      {"min-likelihood", "P", "posecsv: a point with a lower likelihood (SLEAP: score) makes its frame missing",
       "0.6, DeepLabCut's pcutoff"},
      {"stage", "FILE", "tierpsy *_skeletons.hdf5: Tierpsy's masked video, for its /stage_position_pix", ""},
      {"no-stage", "", "tierpsy *_skeletons.hdf5: keep image coordinates, ignore the stage data", ""},
      {"flip-sign", "", "npy: negate the angles (the other polarity convention)", ""},
      {"frames", "FIRST:LAST", "keep only frames FIRST … LAST (0-based, inclusive; time re-zeroed at FIRST)", "all"},
      {"interpolate-gaps", "N", "fill runs of at most N missing frames (shape and pose interpolated)",
       "0 = keep missing"},
      {"lowpass", "HZ", "filter the joint angles: 2nd-order Butterworth at HZ (the paper: 5)", "off"},
      {"causal", "", "with --lowpass: forward only instead of zero phase", ""},
  };
  const std::string usage = Usage(
      "wormdrag import", "FILE --out K.csv [options]",
      "Converts a tracker's output to a kinematics file: Schafer-lab Worm Tracker 2 features\n"
      ".mat (worm.posture.skeleton, µm), WCON (JSON), a NumPy joint-angle kymogram (shape\n"
      "only: built with unit body length, head at the origin), one worm of a CeleST swim-test\n"
      "segmentation (wormSegm_*.txt, pixels; flagged and glitch frames become missing, head/tail\n"
      "ordered by continuity, head from the direction of motion), one worm of a Tierpsy\n"
      "*_featuresN.hdf5 (µm on the plate) or *_skeletons.hdf5 (pixels; put on the plate with the\n"
      "stage data of a stage-tracking video), fps and scale from the file's attributes, or a\n"
      "pose-tool CSV in pixels (DeepLabCut, multi-animal DeepLabCut, SLEAP, plain x0,y0,…;\n"
      "body parts head → tail; needs --fps and --um-per-px). Missing and dropped frames are\n"
      "kept as missing unless --interpolate-gaps fills the short ones. --frames cuts a segment\n"
      "(any format, also a kinematics .csv), before gaps are filled and the filter runs.",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("import", args.status());
  if (args->positionals().size() != 1)
    return Fail("import", Status::InvalidArgument("expected one FILE to import; see --help"));
  const std::string in = args->positionals()[0];
  auto out = args->Require("out");
  if (!out.ok()) return Fail("import", out.status());
  auto fps = args->GetDouble("fps", 0);
  auto gaps = args->GetInt("interpolate-gaps", 0);
  auto lowpass = args->GetDouble("lowpass", 0);
  auto mm_per_px = args->GetDouble("mm-per-px", 0);
  auto um_per_px = args->GetDouble("um-per-px", 0);
  for (const Status& s : {fps.status(), gaps.status(), lowpass.status(), mm_per_px.status(), um_per_px.status()})
    if (!s.ok()) return Fail("import", s);
  if (*fps < 0 || *gaps < 0 || *lowpass < 0 || *mm_per_px < 0 || *um_per_px < 0)
    return Fail("import",
                Status::InvalidArgument(
                    "--fps, --mm-per-px, --um-per-px, --interpolate-gaps and --lowpass must not be negative"));
  if (*mm_per_px > 0 && *um_per_px > 0)
    return Fail("import", Status::InvalidArgument("give the scale once: --mm-per-px or --um-per-px"));
  const double scale_um = *um_per_px > 0 ? *um_per_px : *mm_per_px * 1000;

  auto imported = ReadInFormat(in, *args, *fps, scale_um);
  if (!imported.ok()) return Fail("import", imported.status());
  const std::string& summary = imported->summary;
  Kinematics& k = imported->kinematics;
  if (args->Has("frames")) {
    Status cut = CutFrames(args->Get("frames"), in, &k);
    if (!cut.ok()) return Fail("import", cut);
  }
  const int missing_before = static_cast<int>(k.frames.size()) - k.NumValid();
  const int filled = InterpolateShortGaps(k, static_cast<int>(*gaps));
  if (*lowpass > 0) {
    AngleFilterOptions fo;
    fo.cutoff_hz = *lowpass;
    fo.zero_phase = !args->Has("causal");
    auto f = FilterJointAngles(k, fo);
    if (!f.ok()) return Fail("import", f.status());
    k = std::move(*f);
  }
  Status st = WriteKinematics(k, *out);
  if (!st.ok()) return Fail("import", st);
  if (!summary.empty()) std::fprintf(stderr, "%s\n", summary.c_str());
  if (summary.empty() || args->Has("frames") || filled)
    std::fprintf(stderr, "%s: %zu frames at %.5g fps, %d missing%s, body length %.4g mm\n", in.c_str(), k.frames.size(),
                 k.fps, missing_before, filled ? (", " + std::to_string(filled) + " interpolated").c_str() : "",
                 k.BodyLength());
  return 0;
}

int RunExport(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"wcon", "OUT.wcon", "write the recording as WCON (JSON; units s and mm; missing frames as null)", ""},
  };
  const std::string usage = Usage("wormdrag export", "K.csv --wcon OUT.wcon",
                                  "Writes a kinematics file in another tracker format.", specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
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
