// Import of CeleST ("C. elegans Swim Test", Restif et al. 2014) segmentation files,
// wormSegm_<sample>.txt, with the calibration from CeleST's fileDB.xml.
//
// The file: header lines `format`, `block`, `worms N`, `frames F`, `precision P`; then per
// worm and frame a record `worm WW frame FFFF` with lines `x …` and `y …` (centreline in
// pixels × 10^P, comma-separated, any number of points), `w …` (widths), and one-value
// lines `t` (CeleST's grey threshold), `g` (its worm length, 0 = not measured), `m`
// (missed), `l` (lost), `o` (overlapped). The centreline's head/tail order changes between
// frames and its ends are truncated by varying amounts.
//
// The import of one worm keeps every frame on the file's time base (t = (frame − 1)/fps);
// a frame becomes missing when CeleST flags it, when its centreline is too short, when its
// arc length is far from the worm's median, or when it is an isolated shape glitch. Valid
// frames are ordered head → tail by continuity with the previous valid frame; each run of
// linked frames is then turned so that the body moves head-first on average. Coordinates
// stay in image axes (y down), scaled to mm, as `wormdrag track` writes them.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

struct CelestCalibration {
  double fps = 0;        // frames per second
  double mm_per_px = 0;  // image scale
  std::string origin;    // where the values came from, for the metadata
};

// The sample's entry of a CeleST fileDB.xml: frames_per_second and mm_per_pixel, stored as
// integers × 10^precision (the feature's `precision` attribute). `name` is used in errors.
Result<CelestCalibration> ParseCelestFileDb(std::string_view xml, const std::string& sample, const std::string& name);

// "Sample04" for ".../wormSegm_Sample04.txt" (the file's stem without "wormSegm_").
std::string CelestSampleName(const std::string& segm_path);

// The calibration of a segmentation file: a positive `fps` or `mm_per_px` is used as given;
// the others come from the sample's entry in `filedb` ("" = fileDB.xml beside the file, if
// it exists). An error names what is missing and where it was looked for.
Result<CelestCalibration> ResolveCelestCalibration(const std::string& segm_path, const std::string& filedb, double fps,
                                                   double mm_per_px);

struct CelestOptions {
  int worm = 0;                   // 1-based, as in the file; required
  CelestCalibration calibration;  // fps and mm_per_px required (> 0)
  // Default: 6, why: fewer points than that cover the body with straight chords, and the
  // 14-point resampling would invent the shape between them.
  int min_points = 6;
  // Default: 0.35, why: CeleST truncates the ends by varying amounts (arc length ±8 %
  // typically, up to +32 % in the real samples); beyond ±35 % of the median the centreline
  // is not the body.
  double max_length_deviation = 0.35;
  // A frame whose mean point distance to its neighbours (the better head/tail order)
  // exceeds glitch_factor × the worm's median frame-to-frame distance, and at least
  // glitch_floor of its body length, while its two neighbours agree with each other, is a
  // glitch (an isolated wrong segmentation). Default: 6 and 0.05, why: in the real samples
  // the median step is about 1 px and the glitches 8-17 px; CeleST's re-segmentation every
  // 20 frames moves the centreline as far, but as a step (the next frame agrees), which the
  // neighbour test keeps; the floor keeps a still worm's tiny median from turning noise
  // into glitches.
  double glitch_factor = 6.0;
  double glitch_floor = 0.05;
  // Default: 10 frames, why: over a longer gap (0.55 s at 18 fps, up to half a stroke of
  // these swimmers) the shape may change too much for continuity to tell head from tail.
  int max_link_gap = 10;
  // Default: 0.2 body lengths, why: a run whose centroid moves less than that along the
  // body axis (net, over the run) has no direction of motion beyond thrashing; its order is
  // left as in the file and reported undecided.
  double min_travel = 0.2;
};

struct CelestSummary {
  int frames = 0;
  int valid = 0;
  // Missing frames by reason (each frame counted once, in this order of precedence).
  int lost = 0, missed = 0, overlapped = 0;  // CeleST's flags l, m, o
  int no_centreline = 0;                     // empty, absent from the file, or fewer than min_points points
  int length_outliers = 0;
  int glitches = 0;
  int swaps_fixed = 0;  // links where the file's order reverses between valid frames
  int runs = 0, runs_flipped = 0, runs_undecided = 0;
  double travel = 0;  // net centroid motion along the body toward the head, body
                      // lengths, summed over runs after orientation (undecided: as found)
  double body_length_mm = 0;
  // "545 frames, 543 valid, missing: 1 length, 1 glitch; 14 head/tail swaps fixed; head from
  //  motion: 0.41 body lengths head-first; body length 1.190 mm" (with several runs:
  //  "3 runs (1 flipped, 1 undecided)" in place of the head)
  std::string Report() const;
};

struct CelestImport {
  Kinematics kinematics;  // mm, every frame of the worm; metadata source, environment, calibration
  CelestSummary summary;
};

// `name` is used in error messages
// ("wormSegm_Sample04.txt:16: worm 01 frame 0002: field 'x': not a list of integers '1a2,3'").
Result<CelestImport> ParseCelest(std::string_view text, const CelestOptions& opt, const std::string& name);
Result<CelestImport> ReadCelest(const std::string& path, const CelestOptions& opt);

}  // namespace wormdrag
