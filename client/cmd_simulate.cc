// wormdrag simulate / generate
#include <cmath>
#include <cstdio>
#include <cstring>

#include "client/cli.h"
#include "client/commands.h"
#include "core/io/kinematics.h"
#include "core/sim/pattern.h"
#include "core/sim/simulator.h"

namespace wormdrag::cli {
namespace {

const std::vector<Option> kSolverOptions = {
    {"solver", "NAME", "inertial (the paper's model, link mass 3.84e-7 g) or quasi-static", "inertial"},
    {"eps", "E", "smooth-sign width of the Coulomb law, mm/s", "1e-4"},
    {"substeps", "S", "solver knots per frame interval (more = more accurate)", "2"},
};

Result<SimOptions> SimOptionsFrom(const Args& a) {
  SimOptions o;
  auto solver = ParseSolver(a.Get("solver", "inertial"));
  if (!solver.ok()) return solver.status();
  o.solver = *solver;
  auto eps = a.GetDouble("eps", kDefaultEpsilon);
  if (!eps.ok()) return eps.status();
  o.epsilon = *eps;
  WORMDRAG_RETURN_IF_ERROR(o.Validate());
  return o;
}

Result<int> SubstepsFrom(const Args& a) {
  auto s = a.GetIntIn("substeps", ShapeDriveOptions().substeps, 1, 1000);
  if (!s.ok()) return s.status();
  return static_cast<int>(*s);
}

}  // namespace

int RunSimulate(const std::vector<std::string>& cmdline) {
  std::vector<Option> specs = {
      {"kinematics", "K.csv", "recording whose joint angles drive the model (docs/conventions.md §6 format)", ""},
      {"coef", "MUN,MUT,ETAN,ETAT", "friction coefficients per link (uN, uN, uN.s/mm, uN.s/mm)", ""},
      {"out", "SIM.csv", "where to write the simulated 14 points of every frame", ""},
  };
  specs.insert(specs.end(), kSolverOptions.begin(), kSolverOptions.end());
  const std::string usage = Usage("wormdrag simulate",
                                  "--kinematics K.csv --coef MUN,MUT,ETAN,ETAT --out SIM.csv [options]",
                                  "Simulates the 13-link body driven by the recording's joint angles, starting at the\n"
                                  "first valid frame's pose, and writes the simulated points in the kinematics format.",
                                  specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("simulate", args.status());
  auto kpath = args->Require("kinematics");
  auto cstr = args->Require("coef");
  auto out = args->Require("out");
  for (const auto* r : {&kpath, &cstr, &out})
    if (!r->ok()) return Fail("simulate", r->status());
  auto coef = ParseCoefficients(*cstr);
  if (!coef.ok()) return Fail("simulate", coef.status().Annotate("--coef"));
  auto sim = SimOptionsFrom(*args);
  if (!sim.ok()) return Fail("simulate", sim.status());
  auto substeps = SubstepsFrom(*args);
  if (!substeps.ok()) return Fail("simulate", substeps.status());
  auto k = ReadKinematics(*kpath);
  if (!k.ok()) return Fail("simulate", k.status());
  BodyModel body;
  body.length = k->BodyLength();
  auto drive = ShapeDrive::Build(*k, body, {*substeps});
  if (!drive.ok()) return Fail("simulate", drive.status().Annotate(*kpath));
  Trajectory traj = Simulator::Simulate(*drive, *coef, *sim);
  if (!traj.summary.singular.empty())
    return Fail("simulate", Status::FailedPrecondition("coefficients " + coef->ToString() + " are singular for the " +
                                                       SolverName(sim->solver) + " solver: " + traj.summary.singular));
  if (traj.summary.unconverged > 0)
    return Fail("simulate", Status::Internal("velocity solver did not converge: " + traj.summary.OneLineReport()));
  Kinematics result = TrajectoryToKinematics(*drive, traj, *k);
  result.metadata["coefficients"] = coef->ToString();
  result.metadata["solver"] = SolverName(sim->solver);
  if (Status st = WriteKinematics(result, *out); !st.ok()) return Fail("simulate", st);
  std::fprintf(stderr, "wormdrag simulate: %d frames, body length %.4g mm, %s\n", drive->num_frames(), body.length,
               traj.summary.OneLineReport().c_str());
  return 0;
}

int RunGenerate(const std::vector<std::string>& cmdline) {
  std::vector<Option> specs = {
      {"pattern", "A,B", "amplitude and offset of q_i(t) = A sin(omega t - k i) + B, rad", ""},
      {"omega", "W", "angular frequency, rad/s", "5"},
      {"wavenumber", "K", "phase lag per joint, rad", "0.6"},
      {"coef", "MUN,MUT,ETAN,ETAT", "friction coefficients per link", ""},
      {"fps", "F", "frames per second", "300"},
      {"duration", "T", "length of the recording, s", "5"},
      {"length", "L", "body length, mm", "1"},
      {"out", "K.csv", "where to write the recording", ""},
  };
  specs.insert(specs.end(), kSolverOptions.begin(), kSolverOptions.end());
  specs.back().default_value = "4";  // generation runs finer than estimation
  const std::string usage = Usage(
      "wormdrag generate", "--pattern A,B --coef MUN,MUT,ETAN,ETAT --out K.csv [options]",
      "Simulates the paper's travelling-wave joint-angle pattern with the given friction and\n"
      "writes the resulting recording (head starting at the origin, link 1 along +x).",
      specs);
  if (PrintedHelp(cmdline, usage)) return 0;
  auto args = Args::Parse(cmdline, specs);
  if (!args.ok()) return Fail("generate", args.status());
  auto pat = args->Require("pattern");
  auto cstr = args->Require("coef");
  auto out = args->Require("out");
  for (const auto* r : {&pat, &cstr, &out})
    if (!r->ok()) return Fail("generate", r->status());
  JointPattern p;
  {
    double a, b;
    char tail;
    if (std::sscanf(pat->c_str(), "%lf,%lf%c", &a, &b, &tail) != 2 || !std::isfinite(a) || !std::isfinite(b))
      return Fail("generate", Status::InvalidArgument("--pattern: expected A,B (two numbers), got '" + *pat + "'"));
    p.amplitude = a;
    p.offset = b;
  }
  auto coef = ParseCoefficients(*cstr);
  if (!coef.ok()) return Fail("generate", coef.status().Annotate("--coef"));
  auto omega = args->GetDouble("omega", 5), k = args->GetDouble("wavenumber", 0.6), fps = args->GetDouble("fps", 300),
       dur = args->GetDouble("duration", 5), len = args->GetDouble("length", 1);
  for (const auto* r : {&omega, &k, &fps, &dur, &len})
    if (!r->ok()) return Fail("generate", r->status());
  if (*fps <= 0 || *dur <= 0 || *len <= 0)
    return Fail("generate", Status::InvalidArgument("--fps, --duration and --length must be positive"));
  p.omega = *omega;
  p.wavenumber = *k;
  auto sim = SimOptionsFrom(*args);
  if (!sim.ok()) return Fail("generate", sim.status());
  auto sub = args->GetIntIn("substeps", 4, 1, 1000);
  if (!sub.ok()) return Fail("generate", sub.status());
  RecordingSpec spec;
  spec.fps = *fps;
  spec.duration = *dur;
  spec.body.length = *len;
  spec.substeps = static_cast<int>(*sub);
  auto rec = GenerateRecording(p, *coef, *sim, spec);
  if (!rec.ok()) return Fail("generate", rec.status());
  if (Status st = WriteKinematics(*rec, *out); !st.ok()) return Fail("generate", st);
  std::fprintf(stderr, "wormdrag generate: wrote %zu frames to %s\n", rec->frames.size(), out->c_str());
  return 0;
}

}  // namespace wormdrag::cli
