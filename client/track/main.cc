// wormdrag-track: the `wormdrag track` command, video (file, multi-page TIFF or folder of
// images) → kinematics CSV. It is its own executable because OpenCV loads ~240 shared
// libraries (GDAL, GStreamer, FFmpeg…), which every other command would otherwise pay for at
// start-up; `wormdrag track` runs it (client/cmd_track.cc).
#include <cstdio>

#include "client/cli.h"
#include "core/io/kinematics.h"
#include "core/video/tracker.h"

namespace wormdrag::cli {
namespace {

// "\r[#####.....] 120/1500" on stderr, at most ~100 updates per run.
video::ProgressFn ProgressBar(const char* label) {
  if (!StderrIsTerminal()) return nullptr;
  return [label, last = -1](int done, int total) mutable {
    const int pct = total > 0 ? 100 * done / total : -1;
    if (pct == last && done != total) return;
    last = pct;
    if (total > 0) {
      constexpr int kWidth = 30;
      const int fill = kWidth * done / total;
      std::fprintf(stderr, "\r%s [%.*s%.*s] %d/%d", label, fill, "##############################", kWidth - fill,
                   "..............................", done, total);
      if (done == total) std::fputc('\n', stderr);
    } else if (done % 50 == 0) {
      std::fprintf(stderr, "\r%s %d frames", label, done);
    }
  };
}

Result<video::Polarity> ParsePolarity(const std::string& s) {
  if (s == "auto") return video::Polarity::kAuto;
  if (s == "dark") return video::Polarity::kDarkOnLight;
  if (s == "light") return video::Polarity::kLightOnDark;
  return Status::InvalidArgument("--polarity must be auto, dark (dark worm on light) or light, not '" + s + "'");
}

int RunTrack(const std::vector<std::string>& cmdline) {
  const std::vector<Option> specs = {
      {"out", "K.csv", "kinematics file to write (docs/conventions.md §6)", ""},
      {"fps", "F", "frame rate; required when the input declares none (TIFF, folder)", "from the video"},
      {"um-per-px", "S",
       "calibration, micrometres per pixel; without it the file is in pixels (# units: px) and needs a # px_per_mm "
       "line before other commands read it",
       ""},
      {"quality", "Q.csv", "per-frame status and quality (docs/video.md)", "K.quality.csv beside --out"},
      {"overlay", "OUT", "draw the skeletons on the frames: OUT.avi/.mp4 video, else a folder of PNGs", ""},
      {"polarity", "P", "auto, dark (dark worm, bright-field) or light (light worm, dark-field)", "auto"},
      {"background-kernel", "PX", "background filter size, must exceed the worm's width", "min(w,h)/5"},
      {"blur", "SIGMA", "denoising Gaussian, px", "1"},
      {"mask-fraction", "F", "mask cut at this fraction of the worm's contrast", "0.35"},
      {"keep-border", "", "keep frames where the worm touches the image border", ""},
      {"crops", "", "every frame is a separate crop around the worm: positions are not compared between frames", ""},
      {"first-frame", "N", "skip the frames before N", "0"},
      {"max-frames", "N", "track at most N frames", "all"},
  };
  const std::string usage = Usage(
      "wormdrag track", "INPUT --out K.csv [--fps F] [--um-per-px S] [--overlay OUT] [options]",
      "Tracks the worm's midline in INPUT (a video file, a multi-page TIFF or a folder of\n"
      "images): background removal, binarisation (polarity found automatically), the worm's\n"
      "component, Zhang-Suen skeleton, longest path, sub-pixel refinement, head/tail from\n"
      "continuity, direction of motion and the head's larger swing, 13 equal parts. Frames\n"
      "where the worm touches the border, is coiled, touches itself or has no usable\n"
      "skeleton are written as missing (bodies of short coils are carried along the track);\n"
      "each frame's status and quality go to a side file (--quality). Image axes are kept\n"
      "(x right, y down).",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("track", args.status());
  if (args->positionals().size() != 1)
    return Fail("track", Status::InvalidArgument("expected one INPUT (video, TIFF or folder); see --help"));
  const std::string input = args->positionals()[0];
  auto out = args->Require("out");
  if (!out.ok()) return Fail("track", out.status());

  video::TrackOptions opt;
  auto fps = args->GetDouble("fps", 0);
  auto um = args->GetDouble("um-per-px", 0);
  auto kernel = args->GetInt("background-kernel", 0);
  auto blur = args->GetDouble("blur", opt.denoise_sigma_px);
  auto frac = args->GetDouble("mask-fraction", opt.mask_fraction);
  auto first = args->GetInt("first-frame", 0);
  auto maxf = args->GetInt("max-frames", 0);
  auto pol = ParsePolarity(args->Get("polarity", "auto"));
  for (const Status& s : {fps.status(), um.status(), kernel.status(), blur.status(), frac.status(), first.status(),
                          maxf.status(), pol.status()})
    if (!s.ok()) return Fail("track", s);
  if (*fps < 0 || *um < 0 || *kernel < 0 || *blur < 0 || *first < 0 || *maxf < 0)
    return Fail("track", Status::InvalidArgument("--fps, --um-per-px, --background-kernel, --blur, "
                                                 "--first-frame and --max-frames must not be negative"));
  if (!(*frac > 0 && *frac < 1)) return Fail("track", Status::InvalidArgument("--mask-fraction must be in (0, 1)"));
  opt.fps = *fps;
  opt.um_per_px = *um;
  opt.background_kernel_px = static_cast<int>(*kernel);
  opt.denoise_sigma_px = *blur;
  opt.mask_fraction = *frac;
  opt.first_frame = static_cast<int>(*first);
  opt.max_frames = static_cast<int>(*maxf);
  opt.polarity = *pol;
  opt.reject_border = !args->Has("keep-border");
  opt.positions_comparable = !args->Has("crops");

  auto result = video::TrackFile(input, opt, ProgressBar("track"));
  if (!result.ok()) return Fail("track", result.status());
  if (opt.um_per_px <= 0)
    std::fprintf(stderr, "wormdrag track: warning: no --um-per-px: lengths in %s are pixels\n", out->c_str());
  Status st = WriteKinematics(result->kinematics, *out);
  if (!st.ok()) return Fail("track", st);
  st = WriteFrameQuality(result->quality, args->Get("quality", QualityPathFor(*out)));
  if (!st.ok()) return Fail("track", st);
  std::fprintf(stderr, "%s: %s\n", input.c_str(), result->summary.Report().c_str());
  if (args->Has("overlay")) {
    st = video::WriteOverlay(input, *result, opt, args->Get("overlay"), ProgressBar("overlay"));
    if (!st.ok()) return Fail("track", st);
  }
  return 0;
}

}  // namespace
}  // namespace wormdrag::cli

// The command line is that of `wormdrag track …`, as client/cmd_track.cc passes it on.
int main(int argc, char** argv) {
  const std::vector<std::string> words = wormdrag::flags::ArgList(argc, argv);
  if (words.empty() || words[0] != "track") {
    std::fprintf(stderr, "wormdrag-track: runs as `wormdrag track INPUT --out K.csv …` (see wormdrag track --help)\n");
    return 2;
  }
  return wormdrag::cli::RunTrack({words.begin() + 1, words.end()});
}
