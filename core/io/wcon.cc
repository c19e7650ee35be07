#include "core/io/wcon.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <nlohmann/json.hpp>

namespace wormdrag {

using nlohmann::json;

namespace {

Result<double> LengthScaleToMm(const std::string& u, const std::string& where) {
  static const std::map<std::string, double> kUnits = {
      {"mm", 1.0},           {"millimeter", 1.0},  {"millimeters", 1.0},  {"millimetre", 1.0}, {"millimetres", 1.0},
      {"um", 1e-3},          {"µm", 1e-3},         {"micron", 1e-3},      {"microns", 1e-3},   {"micrometer", 1e-3},
      {"micrometers", 1e-3}, {"micrometre", 1e-3}, {"micrometres", 1e-3}, {"m", 1e3},          {"meter", 1e3},
      {"meters", 1e3},       {"cm", 10.0},         {"centimeter", 10.0}};
  auto it = kUnits.find(u);
  if (it == kUnits.end())
    return Status::InvalidArgument(where + ": length unit '" + u + "' not supported (mm, um, cm, m)");
  return it->second;
}

Result<double> TimeScaleToS(const std::string& u, const std::string& where) {
  if (u == "s" || u == "second" || u == "seconds" || u == "sec") return 1.0;
  if (u == "ms" || u == "millisecond" || u == "milliseconds") return 1e-3;
  if (u == "min" || u == "minute" || u == "minutes") return 60.0;
  return Status::InvalidArgument(where + ": time unit '" + u + "' not supported (s, ms, min)");
}

struct Sample {
  double t;
  bool valid;
  std::vector<Vec2> line;
};

// Value of a per-time field (scalar for all times, or one entry per time), or 0.
double PerTime(const json& rec, const char* key, size_t i, size_t nt) {
  if (!rec.contains(key)) return 0;
  const json& v = rec[key];
  if (v.is_number()) return v.get<double>();
  if (v.is_array() && v.size() == nt && v[i].is_number()) return v[i].get<double>();
  return 0;
}

// Scales of WCON's units to s and mm.
struct UnitScales {
  double t = 1, x = 1, y = 1;
};

Result<UnitScales> ScalesOf(const json& units, const std::string& name) {
  auto unit = [&](const char* k) -> std::string {
    return units.contains(k) && units[k].is_string() ? units[k].get<std::string>() : "";
  };
  if (unit("t").empty() || unit("x").empty() || unit("y").empty())
    return Status::InvalidArgument(name + ": 'units' must give t, x and y");
  auto ts = TimeScaleToS(unit("t"), name + ": units.t");
  auto xs = LengthScaleToMm(unit("x"), name + ": units.x");
  auto ys = LengthScaleToMm(unit("y"), name + ": units.y");
  for (const Status& st : {ts.status(), xs.status(), ys.status()})
    if (!st.ok()) return st;
  return UnitScales{*ts, *xs, *ys};
}

// The centreline of time i of record `rec` (one time when `single`), in mm; not valid
// where a coordinate is missing or not finite, or fewer than 3 points remain.
Result<Sample> SampleAt(const json& rec, size_t i, size_t nt, bool single, const UnitScales& u,
                        const std::string& where) {
  const json& t = rec["t"];
  const json& ti = single ? t : t[i];
  if (!ti.is_number() || !std::isfinite(ti.get<double>() * u.t))
    return Status::InvalidArgument(where + ".t[" + std::to_string(i) + "]: not a finite number");
  const json& x = single ? rec["x"] : rec["x"][i];
  const json& y = single ? rec["y"] : rec["y"][i];
  Sample s{ti.get<double>() * u.t, true, {}};
  if (!x.is_array() || !y.is_array() || x.size() != y.size()) {
    if (!(x.is_null() || x.is_array()) || !(y.is_null() || y.is_array()))
      return Status::InvalidArgument(where + ".x/y[" + std::to_string(i) + "]: not lists of equal length");
    s.valid = false;
    return s;
  }
  const double ox = PerTime(rec, "ox", i, nt), oy = PerTime(rec, "oy", i, nt);
  for (size_t j = 0; j < x.size() && s.valid; ++j) {
    if (!x[j].is_number() || !y[j].is_number()) {
      s.valid = false;
      break;
    }
    const Vec2 p((x[j].get<double>() + ox) * u.x, (y[j].get<double>() + oy) * u.y);
    if (!p.allFinite()) {
      s.valid = false;
      break;
    }
    s.line.push_back(p);
  }
  if (s.line.size() < 3) s.valid = false;
  return s;
}

// The samples of every record of worm `id` (the first record's when empty; then set).
Result<std::vector<Sample>> SamplesOf(const json& doc, const UnitScales& u, const std::string& name, std::string* id) {
  json records = doc["data"].is_array() ? doc["data"] : json::array({doc["data"]});
  std::vector<Sample> samples;
  for (size_t r = 0; r < records.size(); ++r) {
    const json& rec = records[r];
    const std::string where = name + ": data[" + std::to_string(r) + "]";
    if (!rec.is_object()) return Status::InvalidArgument(where + ": not an object");
    std::string rid = rec.contains("id") ? (rec["id"].is_string() ? rec["id"].get<std::string>() : rec["id"].dump())
                                         : "";
    if (id->empty()) *id = rid;
    if (rid != *id) continue;
    if (!rec.contains("t") || !rec.contains("x") || !rec.contains("y"))
      return Status::InvalidArgument(where + ": needs t, x and y");
    const json& t = rec["t"];
    const bool single = t.is_number();
    if (!single && !t.is_array()) return Status::InvalidArgument(where + ".t: not a number or list");
    const size_t nt = single ? 1 : t.size();
    // With a list of times, x and y hold one entry (a list of coordinates) per time.
    for (const char* key : {"x", "y"})
      if (!single && (!rec[key].is_array() || rec[key].size() != nt))
        return Status::InvalidArgument(where + "." + key + ": not a list with one entry per time (" +
                                       std::to_string(nt) + ")");
    for (size_t i = 0; i < nt; ++i) {
      auto s = SampleAt(rec, i, nt, single, u, where);
      if (!s.ok()) return s.status();
      samples.push_back(std::move(*s));
    }
  }
  if (samples.empty()) return Status::InvalidArgument(name + ": no data for worm id '" + *id + "'");
  std::stable_sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.t < b.t; });
  return samples;
}

// The frame rate: given, stored by wormdrag, or the lower median of the time steps
// (dropped frames only ever lengthen steps).
Result<double> FrameRate(const json& doc, const std::vector<Sample>& samples, double fps, const std::string& name) {
  if (!(fps > 0) && doc.contains("@wormdrag") && doc["@wormdrag"].contains("fps") &&
      doc["@wormdrag"]["fps"].is_number())
    fps = doc["@wormdrag"]["fps"].get<double>();
  if (fps > 0 && std::isfinite(fps)) return fps;
  std::vector<double> dt;
  for (size_t i = 1; i < samples.size(); ++i)
    if (samples[i].t > samples[i - 1].t) dt.push_back(samples[i].t - samples[i - 1].t);
  if (dt.empty()) return Status::InvalidArgument(name + ": cannot infer the frame rate from one time; give --fps");
  const size_t mid = (dt.size() - 1) / 2;
  std::nth_element(dt.begin(), dt.begin() + mid, dt.end());
  return 1.0 / dt[mid];
}

// Every sample placed on the frame grid t0 + i/fps; frames with no sample stay missing.
Status PlaceOnFrames(const std::vector<Sample>& samples, const std::string& name, Kinematics* k) {
  const double fps = k->fps;
  const double t0 = samples.front().t;
  // The frame grid is sized from the time span: checked before it is allocated.
  const double span = (samples.back().t - t0) * fps;
  if (!(span < kMaxFrames))
    return Status::InvalidArgument(name + ": data t spans " + std::to_string(samples.back().t - t0) + " s, " +
                                   std::to_string(span) + " frames at " + std::to_string(fps) + " fps; at most " +
                                   std::to_string(kMaxFrames) + " frames are supported (is the frame rate right?)");
  const int nframes = static_cast<int>(std::lround(span)) + 1;
  k->frames.resize(nframes);
  for (int i = 0; i < nframes; ++i) k->frames[i].t = t0 + i / fps;
  for (const Sample& s : samples) {
    const int i = static_cast<int>(std::lround((s.t - t0) * fps));
    if (!s.valid || i < 0 || i >= nframes) continue;
    auto pts = ResampleByArcLength(s.line);
    if (!pts.ok()) continue;
    Frame& f = k->frames[i];
    f.valid = true;
    f.p = *pts;
    f.arc_length = ArcLength(s.line);
  }
  return Status::Ok();
}

}  // namespace

Result<Kinematics> ParseWcon(const std::string& text, const WconReadOptions& opt, const std::string& name) {
  json doc = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return Status::InvalidArgument(name + ": not valid JSON");
  if (!doc.is_object()) return Status::InvalidArgument(name + ": a WCON file is a JSON object");
  if (!doc.contains("units") || !doc["units"].is_object())
    return Status::InvalidArgument(name + ": field 'units' missing (required by WCON)");
  if (!doc.contains("data")) return Status::InvalidArgument(name + ": field 'data' missing");
  auto scales = ScalesOf(doc["units"], name);
  if (!scales.ok()) return scales.status();
  std::string id = opt.id;
  auto samples = SamplesOf(doc, *scales, name, &id);
  if (!samples.ok()) return samples.status();
  auto fps = FrameRate(doc, *samples, opt.fps, name);
  if (!fps.ok()) return fps.status();
  Kinematics k;
  k.fps = *fps;
  k.metadata["fps"] = std::to_string(*fps);
  k.metadata["source"] = "WCON " + name + " id " + id;
  if (doc.contains("@wormdrag") && doc["@wormdrag"].is_object())
    for (auto& [key, v] : doc["@wormdrag"].items())
      if (v.is_string() && key != "fps" && key != "source") k.metadata[key] = v.get<std::string>();
  WORMDRAG_RETURN_IF_ERROR(PlaceOnFrames(*samples, name, &k));
  return k;
}

Result<Kinematics> ReadWcon(const std::string& path, const WconReadOptions& opt) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  return ParseWcon(*text, opt, path);
}

std::string FormatWcon(const Kinematics& k) {
  json t = json::array(), x = json::array(), y = json::array();
  for (const Frame& f : k.frames) {
    t.push_back(f.t);
    json xs = json::array(), ys = json::array();
    for (int j = 0; j < kNumPoints; ++j) {
      if (f.valid) {
        xs.push_back(f.p[j].x());
        ys.push_back(f.p[j].y());
      } else {
        xs.push_back(nullptr);
        ys.push_back(nullptr);
      }
    }
    x.push_back(xs);
    y.push_back(ys);
  }
  json meta = json::object();
  for (const auto& [key, v] : k.metadata) meta[key] = v;
  meta["fps"] = k.fps;
  json doc = {{"units", {{"t", "s"}, {"x", "mm"}, {"y", "mm"}}},
              {"metadata", {{"software", {{"name", "wormdrag"}}}}},
              {"@wormdrag", meta},
              {"data", json::array({{{"id", "1"}, {"t", t}, {"x", x}, {"y", y}}})}};
  return doc.dump() + "\n";
}

Status WriteWcon(const Kinematics& k, const std::string& path) {
  return WriteFileAtomically(path, FormatWcon(k));
}

}  // namespace wormdrag
