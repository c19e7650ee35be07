// WCON, the worm tracker community's JSON format (openworm/tracker-commons), read and
// written with nlohmann::json. Read: "units" (t in s/ms/min; x, y in mm/um/m/cm),
// "data" as one record or a list, records with "id", "t" (number or list), "x"/"y"
// (list per time, or one list for a single time), optional origin offsets "ox"/"oy";
// records of the chosen id are merged by time. null or empty coordinates = missing
// frame; time steps longer than 1.5 frame intervals (dropped frames) become missing
// frames too, so the recording keeps its time base.
#pragma once

#include <string>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

struct WconReadOptions {
  std::string id;  // worm to import; "" = the first id in the file
  double fps = 0;  // 0: "@wormdrag".fps if present, else 1 / median time step
};

Result<Kinematics> ParseWcon(const std::string& text, const WconReadOptions& opt, const std::string& name);
Result<Kinematics> ReadWcon(const std::string& path, const WconReadOptions& opt = {});

// One worm (id "1"), units s and mm, every frame listed; a missing frame has null
// coordinates. Kinematics metadata go to the custom "@wormdrag" object.
std::string FormatWcon(const Kinematics& k);
Status WriteWcon(const Kinematics& k, const std::string& path);

}  // namespace wormdrag
