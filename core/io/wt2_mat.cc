#include "core/io/wt2_mat.h"

#include <cmath>
#include <limits>
#include <memory>

#include <matio.h>

namespace wormdrag {

namespace {

struct MatCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct VarFreer {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};

// Follows a dotted path of struct fields below `root` ("posture.skeleton.x").
const matvar_t* Field(const matvar_t* root, const std::string& dotted) {
  const matvar_t* v = root;
  size_t start = 0;
  while (v && start <= dotted.size()) {
    const size_t dot = dotted.find('.', start);
    const std::string name = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    // matio's lookup by name dereferences the field names and the field array without
    // checking them: a damaged file can leave either null or short. The field is found
    // here among the names that exist, then taken by index from an array of the size
    // the struct claims.
    if (v->class_type != MAT_C_STRUCT || !v->data) return nullptr;
    const unsigned nfields = Mat_VarGetNumberOfFields(const_cast<matvar_t*>(v));
    char* const* names = Mat_VarGetStructFieldnames(v);
    if (nfields == 0 || !names || v->nbytes < nfields * sizeof(matvar_t*)) return nullptr;
    int index = -1;
    for (unsigned i = 0; i < nfields && index < 0; ++i)
      if (names[i] && name == names[i]) index = static_cast<int>(i);
    if (index < 0) return nullptr;
    v = Mat_VarGetStructFieldByIndex(const_cast<matvar_t*>(v), static_cast<size_t>(index), 0);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return v;
}

constexpr size_t kMaxArrayElements = 25'000'000;

// A real numeric array as doubles (column-major, MATLAB order).
Result<std::vector<double>> Doubles(const matvar_t* v, const std::string& what) {
  if (!v) return Status::InvalidArgument(what + ": field missing");
  if (v->isComplex || !v->data) return Status::InvalidArgument(what + ": not a real numeric array");
  size_t n = 1;
  for (int i = 0; i < v->rank; ++i) {
    if (v->dims[i] != 0 && n > std::numeric_limits<size_t>::max() / v->dims[i])
      return Status::InvalidArgument(what + ": dimensions overflow");
    n *= v->dims[i];
  }
  // The dimensions are the file's claim; the buffer matio read is nbytes long.
  const size_t width = Mat_SizeOf(v->data_type);
  if (width == 0 || n > v->nbytes / width)
    return Status::InvalidArgument(what + ": dimensions larger than the data stored");
  // A compressed variable of a few bytes can inflate to gigabytes of 1-byte integers,
  // each becoming a double here; real WT2 arrays stay far below this (49 points x
  // 500 000 frames, hours of video).
  if (n > kMaxArrayElements)
    return Status::InvalidArgument(what + ": " + std::to_string(n) + " elements; at most " +
                                   std::to_string(kMaxArrayElements) + " are supported");
  std::vector<double> out(n);
  auto copy = [&](auto* p) {
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<double>(p[i]);
  };
  switch (v->data_type) {
    case MAT_T_DOUBLE:
      copy(static_cast<const double*>(v->data));
      break;
    case MAT_T_SINGLE:
      copy(static_cast<const float*>(v->data));
      break;
    case MAT_T_INT8:
      copy(static_cast<const int8_t*>(v->data));
      break;
    case MAT_T_UINT8:
      copy(static_cast<const uint8_t*>(v->data));
      break;
    case MAT_T_INT16:
      copy(static_cast<const int16_t*>(v->data));
      break;
    case MAT_T_UINT16:
      copy(static_cast<const uint16_t*>(v->data));
      break;
    case MAT_T_INT32:
      copy(static_cast<const int32_t*>(v->data));
      break;
    case MAT_T_UINT32:
      copy(static_cast<const uint32_t*>(v->data));
      break;
    case MAT_T_INT64:
      copy(static_cast<const int64_t*>(v->data));
      break;
    case MAT_T_UINT64:
      copy(static_cast<const uint64_t*>(v->data));
      break;
    default:
      return Status::InvalidArgument(what + ": unsupported numeric type");
  }
  return out;
}

}  // namespace

Result<Wt2Import> ReadWt2Features(const std::string& path) {
  std::unique_ptr<mat_t, MatCloser> mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) return Status::InvalidArgument(path + ": not a readable MATLAB .mat file");
  std::unique_ptr<matvar_t, VarFreer> worm(Mat_VarRead(mat.get(), "worm"));
  std::unique_ptr<matvar_t, VarFreer> info(Mat_VarRead(mat.get(), "info"));
  if (!worm) return Status::InvalidArgument(path + ": no variable 'worm' (not a WT2 features file)");
  if (!info) return Status::InvalidArgument(path + ": no variable 'info' (not a WT2 features file)");

  const matvar_t* xv = Field(worm.get(), "posture.skeleton.x");
  const matvar_t* yv = Field(worm.get(), "posture.skeleton.y");
  auto x = Doubles(xv, path + ": worm.posture.skeleton.x");
  if (!x.ok()) return x.status();
  auto y = Doubles(yv, path + ": worm.posture.skeleton.y");
  if (!y.ok()) return y.status();
  if (xv->rank != 2 || yv->rank != 2 || xv->dims[0] != yv->dims[0] || xv->dims[1] != yv->dims[1])
    return Status::InvalidArgument(path + ": worm.posture.skeleton.x and .y must be 2-D arrays of equal size");
  if (xv->dims[0] > 100000 || xv->dims[1] > static_cast<size_t>(kMaxFrames))
    return Status::InvalidArgument(path + ": worm.posture.skeleton is " + std::to_string(xv->dims[0]) + " x " +
                                   std::to_string(xv->dims[1]) + "; at most 100000 points x " +
                                   std::to_string(kMaxFrames) + " frames are supported");
  const int npts = static_cast<int>(xv->dims[0]), nframes = static_cast<int>(xv->dims[1]);
  if (npts < 3) return Status::InvalidArgument(path + ": worm.posture.skeleton has fewer than 3 points per frame");

  auto fpsv = Doubles(Field(info.get(), "video.resolution.fps"), path + ": info.video.resolution.fps");
  if (!fpsv.ok()) return fpsv.status();
  if (fpsv->empty() || !(fpsv->front() > 0))
    return Status::InvalidArgument(path + ": info.video.resolution.fps is not a positive number");
  const double fps = fpsv->front();

  Wt2Import out;
  out.points_per_frame = npts;
  if (const matvar_t* a = Field(info.get(), "video.annotations.frames")) {
    auto codes = Doubles(a, "annotations");
    if (codes.ok() && static_cast<int>(codes->size()) == nframes)
      for (double c : *codes) out.annotation.push_back(static_cast<int>(c));
  }
  Kinematics& k = out.kinematics;
  k.fps = fps;
  k.metadata["fps"] = std::to_string(fps);
  k.metadata["source"] = "Worm Tracker 2 features " + path;
  k.metadata["units"] = "mm";
  k.frames.resize(nframes);
  for (int f = 0; f < nframes; ++f) {
    Frame& fr = k.frames[f];
    fr.t = f / fps;
    std::vector<Vec2> line(npts);
    bool ok = true;
    for (int i = 0; i < npts; ++i) {
      // Column-major: element (i, f) at i + f * npts. µm → mm.
      const double xi = (*x)[i + static_cast<size_t>(f) * npts], yi = (*y)[i + static_cast<size_t>(f) * npts];
      if (!std::isfinite(xi) || !std::isfinite(yi)) {
        ok = false;
        break;
      }
      line[i] = Vec2(xi, yi) / 1000.0;
    }
    if (!ok) continue;
    auto pts = ResampleByArcLength(line);
    if (!pts.ok()) continue;
    fr.valid = true;
    fr.p = *pts;
    fr.arc_length = ArcLength(line);
  }
  return out;
}

}  // namespace wormdrag
