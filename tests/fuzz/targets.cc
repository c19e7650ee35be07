#include "tests/fuzz/targets.h"

#include <string>
#include <string_view>

#include <sys/mman.h>
#include <unistd.h>

#include "core/estimate/paired_path.h"
#include "core/io/celest.h"
#include "core/io/kinematics.h"
#include "core/io/kymogram.h"
#include "core/io/wcon.h"
#include "core/io/wt2_mat.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag::fuzz {
namespace {

std::string Text(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

}  // namespace

int KinematicsCsv(const uint8_t* data, size_t size) {
  auto k = ParseKinematics(Text(data, size), "fuzz.csv");
  if (!k.ok()) return 0;
  // What a submission does next with a recording: the work it implies, then the span.
  (void)CheckRecordingWork(*k, "fuzz.csv", EvaluationOptions());
  (void)k->Truncated(5.0).BodyLength();
  (void)FormatKinematics(*k);
  return 0;
}

int Wcon(const uint8_t* data, size_t size) {
  const std::string text = Text(data, size);
  auto k = ParseWcon(text, WconReadOptions(), "fuzz.wcon");
  if (k.ok()) (void)FormatKinematics(*k);
  WconReadOptions with_fps;
  with_fps.fps = 30;
  (void)ParseWcon(text, with_fps, "fuzz.wcon");
  return 0;
}

int Npy(const uint8_t* data, size_t size) {
  auto a = ParseNpy(Text(data, size), "fuzz.npy");
  if (!a.ok()) return 0;
  KymogramOptions o;
  o.fps = 30;
  (void)KymogramToKinematics(*a, o, "fuzz.npy");
  return 0;
}

int Wt2Mat(const uint8_t* data, size_t size) {
  // matio reads files by name: the bytes go to an anonymous in-memory file.
  const int fd = memfd_create("fuzz.mat", 0);
  if (fd < 0) return 0;
  size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd, data + done, size - done);
    if (n <= 0) break;
    done += static_cast<size_t>(n);
  }
  if (done == size) (void)ReadWt2Features("/proc/self/fd/" + std::to_string(fd));
  close(fd);
  return 0;
}

int Celest(const uint8_t* data, size_t size) {
  const std::string text = Text(data, size);
  CelestOptions o;
  o.worm = 1;
  o.calibration = {18.0, 0.01, "fuzz"};
  (void)ParseCelest(text, o, "wormSegm_fuzz.txt");
  // The same bytes as a fileDB.xml calibration.
  (void)ParseCelestFileDb(text, "fuzz", "fileDB.xml");
  return 0;
}

int JobOptions(const uint8_t* data, size_t size) {
  auto o = JobOptionsFromJson(Text(data, size));
  if (!o.ok()) return 0;
  // Accepted options are stored as their canonical JSON, which must read back.
  auto again = JobOptionsFromJson(o->ToJson());
  if (!again.ok() || again->ToJson() != o->ToJson()) __builtin_trap();
  (void)EvalKey({"a", "b"}, *o);
  return 0;
}

const std::vector<Target>& Targets() {
  static const std::vector<Target> targets = {
      {"kinematics_csv", KinematicsCsv}, {"wcon", Wcon}, {"npy", Npy}, {"wt2_mat", Wt2Mat}, {"celest", Celest},
      {"job_options", JobOptions},
  };
  return targets;
}

}  // namespace wormdrag::fuzz
