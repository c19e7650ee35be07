// A Tierpsy file's layout and calibration (internal/tierpsy_source.h).
#include "core/io/internal/tierpsy_source.h"

#include <cmath>

#include "core/common/format.h"

namespace wormdrag::tierpsy_internal {

Result<Source> Detect(const h5::File& f) {
  Source s;
  if (f.IsDataset("/coordinates/skeletons")) {
    s = {Layout::kFeaturesN, "/coordinates/skeletons", "featuresN"};
  } else if (f.IsDataset("/skeleton")) {
    s = {Layout::kSkeletons, "/skeleton", "skeletons"};
  } else if (f.IsDataset("/skeletons") && !f.Has(kTable)) {
    return Source{Layout::kWormPose, "/skeletons", "WormPose"};
  } else {
    return Status::InvalidArgument(f.path() +
                                   ": not a Tierpsy file: it has none of /coordinates/skeletons "
                                   "(featuresN), /skeleton (skeletons) or /skeletons (WormPose)");
  }
  if (!f.IsDataset(kTable))
    return Status::InvalidArgument(f.path() + ": " + kTable + ": missing (Tierpsy's table of worms and frames)");
  return s;
}

namespace {

// Tierpsy's xy_units / microns_per_pixel convention: "pixels" (or no attributes, or a
// scale of exactly 1 without xy_units) means no scale was known.
Result<double> FileScale(const h5::File& f, bool* known) {
  auto units = f.HasAttribute(kTable, "xy_units") ? f.StringAttribute(kTable, "xy_units") : std::string();
  if (!units.ok()) return units.status();
  double mpp = 1;
  if (f.HasAttribute(kTable, "microns_per_pixel")) {
    auto v = f.NumericAttribute(kTable, "microns_per_pixel");
    if (!v.ok()) return v.status();
    mpp = std::abs(v->front());
  }
  *known = *units == "pixels" ? false : !units->empty() || mpp != 1;
  if (*known && !(mpp > 0 && std::isfinite(mpp)))
    return Status::InvalidArgument(f.path() + ": " + kTable + ": attribute 'microns_per_pixel' = " +
                                   FormatNumber(mpp, 10) + " is not a scale; give --um-per-px");
  return mpp;
}

// The file's frame rate (Tierpsy: attribute fps, else expected_fps; WormPose: framerate).
Result<double> FileFps(const h5::File& f, const std::string& object, std::string* from) {
  const std::string where = f.path() + ": " + object;
  auto units = f.HasAttribute(object, "time_units") ? f.StringAttribute(object, "time_units") : std::string();
  if (!units.ok()) return units.status();
  if (*units == "frames")
    return Status::InvalidArgument(where +
                                   ": time_units 'frames': Tierpsy had no frame rate for this video; "
                                   "give --fps");
  std::string attr;
  for (const char* a : {"fps", "expected_fps", "framerate"})
    if (attr.empty() && f.HasAttribute(object, a)) attr = a;
  if (attr.empty())
    return Status::InvalidArgument(where +
                                   ": no frame rate (attribute 'fps', 'expected_fps' or 'framerate'); "
                                   "give --fps");
  auto v = f.NumericAttribute(object, attr);
  if (!v.ok()) return v.status();
  if (!(v->front() > 0 && std::isfinite(v->front())))
    return Status::InvalidArgument(where + ": attribute '" + attr + "' = " + FormatNumber(v->front(), 10) +
                                   " is not a frame rate; give --fps");
  *from = "attribute " + attr;
  return v->front();
}

// µm per pixel of the skeletons; 0 when they are in µm already.
Result<double> PixelScale(const h5::File& f, const Source& src, double user, std::string* from) {
  *from = "--um-per-px";
  if (src.layout == Layout::kFeaturesN) {
    bool known = false;
    auto mpp = FileScale(f, &known);
    if (!mpp.ok()) return mpp.status();
    if (known && user > 0)
      return Status::InvalidArgument(f.path() + ": " + src.skeletons + " is in µm already (xy_units of " + kTable +
                                     "); --um-per-px applies to files in pixels");
    if (!known && !(user > 0))
      return Status::InvalidArgument(f.path() + ": " + kTable +
                                     ": xy_units 'pixels': Tierpsy had no scale for this "
                                     "video, so " +
                                     src.skeletons + " is in pixels; give --um-per-px");
    return known ? 0.0 : user;
  }
  if (user > 0) return user;
  if (src.layout == Layout::kWormPose)
    return Status::InvalidArgument(f.path() +
                                   ": WormPose skeletons are in pixels of each frame's crop and the "
                                   "file has no scale; give --um-per-px");
  if (f.HasAttribute(kStageGroup, "microns_per_pixel_scale")) {  // Tierpsy's precedence for stage tracking
    auto v = f.NumericAttribute(kStageGroup, "microns_per_pixel_scale");
    if (!v.ok()) return v.status();
    *from = "attribute microns_per_pixel_scale of " + std::string(kStageGroup);
    if (!(std::abs(v->front()) > 0 && std::isfinite(v->front())))
      return Status::InvalidArgument(f.path() + ": " + kStageGroup +
                                     ": attribute 'microns_per_pixel_scale' is not "
                                     "a scale; give --um-per-px");
    return std::abs(v->front());
  }
  bool known = false;
  auto mpp = FileScale(f, &known);
  if (!mpp.ok()) return mpp.status();
  if (!known)
    return Status::InvalidArgument(f.path() + ": " + kTable +
                                   ": no scale (xy_units 'pixels' or no attribute "
                                   "'microns_per_pixel'); give --um-per-px");
  *from = "attribute microns_per_pixel";
  return *mpp;
}

}  // namespace

Result<Calibration> ResolveCalibration(const h5::File& f, const Source& src, const TierpsyOptions& opt) {
  Calibration c;
  std::string fps_from = "--fps", scale_from;
  c.fps = opt.fps;
  if (!(opt.fps > 0)) {
    auto fps = FileFps(f, src.layout == Layout::kWormPose ? "/" : kTable, &fps_from);
    if (!fps.ok()) return fps.status();
    c.fps = *fps;
  }
  auto scale = PixelScale(f, src, opt.um_per_px, &scale_from);
  if (!scale.ok()) return scale.status();
  c.um_per_px = *scale;
  c.text = (c.um_per_px > 0 ? FormatNumber(c.um_per_px, 10) + " µm/px (" + scale_from + ")"
                            : std::string("coordinates in µm")) +
           ", " + FormatNumber(c.fps, 10) + " fps (" + fps_from + ")";
  return c;
}

}  // namespace wormdrag::tierpsy_internal
