// CeleST's fileDB.xml: <sequences_database> holds one <sequence> per video, each a list of
// <feature class="…" name="…" precision="P">value</feature>; numbers are stored as integers
// × 10^P. Only this flat layout is read (plain string scanning, no XML library): every
// <feature> must be closed, and the sample's two calibration values must be numbers.
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/io/celest.h"

namespace wormdrag {
namespace {

struct Feature {
  std::string name, precision, value;
  int line = 0;
};

int LineAt(std::string_view text, size_t pos) {
  int line = 1;
  for (size_t i = 0; i < pos && i < text.size(); ++i) line += text[i] == '\n';
  return line;
}

// The value of attribute `attr` in the start tag `tag` ("" if absent).
std::string Attribute(std::string_view tag, const std::string& attr) {
  const std::string key = attr + "=\"";
  size_t p = 0;
  while ((p = tag.find(key, p)) != std::string_view::npos) {
    if (p == 0 || tag[p - 1] == ' ' || tag[p - 1] == '\t' || tag[p - 1] == '\n') {
      const size_t start = p + key.size(), end = tag.find('"', start);
      if (end == std::string_view::npos) return "";
      return std::string(tag.substr(start, end - start));
    }
    p += key.size();
  }
  return "";
}

std::string Trimmed(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

// The features of each <sequence>, in file order.
Result<std::vector<std::vector<Feature>>> Sequences(std::string_view xml, const std::string& name) {
  auto error = [&](size_t pos, const std::string& what) {
    return Status::InvalidArgument(name + ":" + std::to_string(LineAt(xml, pos)) + ": " + what);
  };
  if (xml.find("<sequences_database") == std::string_view::npos)
    return Status::InvalidArgument(name + ": not a CeleST fileDB (no <sequences_database> element)");
  std::vector<std::vector<Feature>> out;
  size_t pos = 0;
  while ((pos = xml.find("<sequence", pos)) != std::string_view::npos) {
    if (xml.compare(pos, 18, "<sequences_database") == 0) {
      pos += 18;
      continue;
    }
    const size_t end = xml.find("</sequence>", pos);
    if (end == std::string_view::npos) return error(pos, "<sequence> is not closed by </sequence>");
    std::vector<Feature>& seq = out.emplace_back();
    size_t f = pos;
    while ((f = xml.find("<feature", f)) != std::string_view::npos && f < end) {
      const size_t close = xml.find('>', f);
      if (close == std::string_view::npos || close > end) return error(f, "<feature> start tag is not closed");
      const std::string_view tag = xml.substr(f, close - f);
      Feature feat{Attribute(tag, "name"), Attribute(tag, "precision"), "", LineAt(xml, f)};
      if (tag.back() != '/') {
        const size_t stop = xml.find("</feature>", close);
        if (stop == std::string_view::npos || stop > end)
          return error(f, "<feature name=\"" + feat.name + "\"> is not closed by </feature>");
        feat.value = Trimmed(xml.substr(close + 1, stop - close - 1));
        f = stop;
      } else {
        f = close;
      }
      seq.push_back(std::move(feat));
    }
    pos = end;
  }
  return out;
}

const Feature* Find(const std::vector<Feature>& seq, const std::string& key) {
  for (const Feature& f : seq)
    if (f.name == key) return &f;
  return nullptr;
}

Result<double> Scaled(const Feature* f, const std::string& sample, const std::string& key, const std::string& name) {
  if (!f) return Status::InvalidArgument(name + ": the entry for " + sample + " has no feature '" + key + "'");
  const std::string where = name + ":" + std::to_string(f->line) + ": " + sample + " " + key;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(f->value.c_str(), &end);
  if (f->value.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v) || !(v > 0))
    return Status::InvalidArgument(where + ": not a positive number '" + f->value + "'");
  long precision = 0;
  if (!f->precision.empty()) {
    precision = std::strtol(f->precision.c_str(), &end, 10);
    if (*end != '\0' || precision < 0 || precision > 12)
      return Status::InvalidArgument(where + ": precision \"" + f->precision + "\" is not 0-12");
  }
  return v / std::pow(10.0, static_cast<double>(precision));
}

}  // namespace

Result<CelestCalibration> ParseCelestFileDb(std::string_view xml, const std::string& sample, const std::string& name) {
  auto seqs = Sequences(xml, name);
  if (!seqs.ok()) return seqs.status();
  std::string listed;
  for (const auto& seq : *seqs) {
    const Feature* id = Find(seq, "name");
    if (!id) continue;
    if (id->value != sample) {
      listed += (listed.empty() ? "" : ", ") + id->value;
      continue;
    }
    auto fps = Scaled(Find(seq, "frames_per_second"), sample, "frames_per_second", name);
    if (!fps.ok()) return fps.status();
    auto scale = Scaled(Find(seq, "mm_per_pixel"), sample, "mm_per_pixel", name);
    if (!scale.ok()) return scale.status();
    return CelestCalibration{*fps, *scale, std::filesystem::path(name).filename().string() + " entry " + sample};
  }
  return Status::InvalidArgument(name + ": no entry for " + sample + " (it lists " +
                                 (listed.empty() ? std::string("none") : listed) + ")");
}

std::string CelestSampleName(const std::string& segm_path) {
  std::string stem = std::filesystem::path(segm_path).stem().string();
  const std::string prefix = "wormSegm_";
  if (stem.compare(0, prefix.size(), prefix) == 0) stem.erase(0, prefix.size());
  return stem;
}

Result<CelestCalibration> ResolveCelestCalibration(const std::string& segm_path, const std::string& filedb, double fps,
                                                   double mm_per_px) {
  CelestCalibration given{fps, mm_per_px, "given"};
  if (fps > 0 && mm_per_px > 0) return given;
  const std::string sample = CelestSampleName(segm_path);
  std::string db = filedb;
  if (db.empty()) {
    db = (std::filesystem::path(segm_path).parent_path() / "fileDB.xml").string();
    if (!std::filesystem::exists(db))
      return Status::InvalidArgument(segm_path + ": no calibration for " + sample + ": no fileDB.xml beside it; give " +
                                     "--filedb, or --fps and --mm-per-px");
  }
  auto text = ReadFile(db);
  if (!text.ok()) return text.status();
  auto cal = ParseCelestFileDb(*text, sample, db);
  if (!cal.ok())
    return Status::InvalidArgument(segm_path + ": no calibration for " + sample + ": " + cal.status().message() +
                                   "; give --fps and --mm-per-px");
  if (fps > 0) {
    cal->fps = fps;
    cal->origin += ", fps given";
  }
  if (mm_per_px > 0) {
    cal->mm_per_px = mm_per_px;
    cal->origin += ", mm/px given";
  }
  return cal;
}

}  // namespace wormdrag
