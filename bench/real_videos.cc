#include "bench/real_videos.h"

#include <cstdio>
#include <cstdlib>
#include <string>

#include <hdf5.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "core/video/frame_source.h"

namespace wormdrag::video {

namespace fs = std::filesystem;

bool ReadWormposeSkeletons(const fs::path& h5, std::vector<double>* data) {
  const hid_t file = H5Fopen(h5.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  bool ok = file >= 0;
  if (ok) {
    const hid_t ds = H5Dopen2(file, "skeletons", H5P_DEFAULT);
    ok = ds >= 0;
    if (ok) {
      data->resize(1000 * 52 * 2);
      ok = H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data->data()) >= 0;
      H5Dclose(ds);
    }
    H5Fclose(file);
  }
  if (!ok) std::printf("cannot read %s\n", h5.c_str());
  return ok;
}

bool ReadWormposeCrops(const fs::path& dir, std::vector<cv::Mat>* crops) {
  for (int i = 0; i < 1000; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%05d.png", i);
    crops->push_back(cv::imread((dir / name).string(), cv::IMREAD_GRAYSCALE));
    if (crops->back().empty()) {
      std::printf("cannot read %s\n", (dir / name).c_str());
      return false;
    }
  }
  return true;
}

TrackOptions WormposeTrackOptions() {
  TrackOptions opt;
  opt.reject_border = false;
  opt.polarity = Polarity::kDarkOnLight;
  opt.background_kernel_px = 15;
  opt.positions_comparable = false;
  return opt;
}

bool ReadWormTracer(const fs::path& shared, const fs::path& work, std::vector<cv::Mat>* frames,
                    std::vector<cv::Mat>* masks) {
  const fs::path avi = shared / "data/real/WormTracer/WT_grayscale.avi";
  const fs::path zip = shared / "data/real/WormTracer/WT_binary_multipage_tiff.zip";
  const fs::path tif = work / "WT_binary.tif";
  if (!fs::exists(tif)) {
    fs::create_directories(work);
    const std::string cmd = "unzip -o -q '" + zip.string() + "' WT_binary.tif -d '" + work.string() + "'";
    if (std::system(cmd.c_str()) != 0) {
      std::printf("unzip of %s failed\n", zip.c_str());
      return false;
    }
  }
  cv::imreadmulti(tif.string(), *masks, cv::IMREAD_GRAYSCALE);
  cv::VideoCapture cap(avi.string());
  cv::Mat f;
  while (cap.read(f)) frames->push_back(ToGray8(f));
  if (frames->empty() || masks->empty()) std::printf("cannot read %s or %s\n", avi.c_str(), tif.c_str());
  return !frames->empty() && !masks->empty();
}

}  // namespace wormdrag::video
