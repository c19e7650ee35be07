#include "bench/shape_refit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Dense>

#include "core/common/parallel.h"
#include "core/filter/shape_modes.h"
#include "core/filter/smoothing_spline.h"
#include "core/model/body.h"
#include "core/sim/simulator.h"

namespace wormdrag {

Status ShapeRefitOptions::Validate() const {
  if (!(knots_per_second > 0)) return Status::InvalidArgument("shape refit: knots_per_second must be > 0");
  if (max_iterations < 1) return Status::InvalidArgument("shape refit: max_iterations must be ≥ 1");
  if (!(shape_step > 0) || !(coefficient_step > 0))
    return Status::InvalidArgument("shape refit: difference steps must be > 0");
  if (!(roughness_scale >= 0)) return Status::InvalidArgument("shape refit: roughness_scale must be ≥ 0");
  if (threads < 1) return Status::InvalidArgument("shape refit: threads must be ≥ 1");
  return Status::Ok();
}

std::string ShapeRefitSummary::OneLineReport() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "shape refit: F %.1f -> %.1f (roughness %.1f) in %d iterations (%s), %d parameters, modes %d + %d, "
                "log det of the shape block %.2f",
                initial_f, final_f, final_roughness, iterations, termination.c_str(), parameters, shape_modes[0],
                shape_modes[1], nuisance_logdet);
  return buf;
}

Eigen::MatrixXd ModeSeries(const ShapeModes& m, const Kinematics& k) {
  Eigen::MatrixXd a(k.frames.size(), kNumJoints);
  for (size_t i = 0; i < k.frames.size(); ++i) a.row(i) = m.ToModes(ShapeOf(k.frames[i].p)).transpose();
  return a;
}

Kinematics WithModeShapes(const Kinematics& base, const ShapeModes& m, const Eigen::MatrixXd& a) {
  Kinematics out = base;
  for (size_t i = 0; i < base.frames.size(); ++i) {
    const Shape shape = m.FromModes(a.row(i).transpose());
    const double l = MeanLinkLength(base.frames[i].p);
    out.frames[i].p = LabPoints(BestFitPose(base.frames[i].p, shape, l), shape, l);
  }
  return out;
}

namespace {

// The uniform cubic B-spline kernel, support |u| < 2.
double CubicBSpline(double u) {
  u = std::abs(u);
  if (u < 1) return 2.0 / 3 - u * u + 0.5 * u * u * u;
  if (u < 2) return (2 - u) * (2 - u) * (2 - u) / 6;
  return 0;
}

// One worm: everything that stays fixed while its shapes are refitted.
struct Worm {
  Kinematics raw, base;  // truncated to t_max; base = the smoothed recording
  BodyModel body;
  int substeps = 1;
  double sigma = 1;
  ShapeModes modes;
  std::vector<int> corrected;  // the modes that carry shape
  Eigen::MatrixXd smoothed;    // [frame][mode]: the smoothed recording's mode coordinates
  std::vector<Pose> poses;     // the smoothed recording's pose of every frame
  std::vector<double> lengths;
  Eigen::MatrixXd basis;                // [frame][knot]
  std::vector<Eigen::MatrixXd> rough;   // per corrected mode: sqrt(λ) D³ basis
  std::vector<Eigen::VectorXd> rough0;  // per corrected mode: sqrt(λ) D³ (smoothed series)
  int frames() const { return static_cast<int>(base.frames.size()); }
  int knots() const { return static_cast<int>(basis.cols()); }
  int params() const { return 3 + static_cast<int>(corrected.size()) * knots(); }
  int data_rows() const { return 2 * kNumPoints * frames(); }
};

Eigen::MatrixXd ThirdDifferences(const Eigen::MatrixXd& x) {
  const int n = static_cast<int>(x.rows()) - 3;
  Eigen::MatrixXd d(std::max(n, 0), x.cols());
  for (int i = 0; i < n; ++i) d.row(i) = x.row(i + 3) - 3 * x.row(i + 2) + 3 * x.row(i + 1) - x.row(i);
  return d;
}

Result<Worm> PrepareWorm(const Kinematics& raw_full, const Kinematics& smoothed_full, double sigma,
                         const EvaluationOptions& eval, const ShapeRefitOptions& opt, const std::string& name) {
  Worm w;
  w.raw = raw_full.Truncated(eval.t_max);
  w.base = smoothed_full.Truncated(eval.t_max);
  if (w.raw.frames.size() != w.base.frames.size() || w.raw.NumValid() != w.frames() || w.frames() < 8)
    return Status::InvalidArgument(name + ": the shape refit needs a gap-free recording of at least 8 frames");
  if (!(sigma > 0)) return Status::InvalidArgument(name + ": the shape refit needs a tracking noise above 0");
  w.sigma = sigma;
  w.body.length = w.base.BodyLength();
  w.substeps = eval.SubstepsFor(w.base.fps);
  auto modes = NoiseWhitenedModes(w.raw);
  if (!modes.ok()) return modes.status();
  w.modes = std::move(*modes);
  const int n = w.frames();
  w.smoothed = ModeSeries(w.modes, w.base);
  for (int i = 0; i < n; ++i) {
    const Points& p = w.base.frames[i].p;
    w.lengths.push_back(MeanLinkLength(p));
    const Shape q = ShapeOf(p);
    w.poses.push_back(BestFitPose(p, q, w.lengths.back()));
  }
  const double t0 = w.base.frames.front().t, duration = w.base.frames.back().t - t0;
  const double spacing = 1 / opt.knots_per_second;
  const int knots = static_cast<int>(std::ceil(duration / spacing)) + 3;
  w.basis.resize(n, knots);
  for (int i = 0; i < n; ++i)
    for (int b = 0; b < knots; ++b) w.basis(i, b) = CubicBSpline((w.base.frames[i].t - t0) / spacing - (b - 1));
  const Eigen::MatrixXd d3_basis = ThirdDifferences(w.basis);
  const Eigen::MatrixXd raw = ModeSeries(w.modes, w.raw);
  for (int m = 0; m < kNumJoints; ++m) {
    if (!(w.modes.snr[m] > kShapeModeSnr)) continue;
    const std::vector<double> series(raw.col(m).data(), raw.col(m).data() + n);
    auto s = SmoothByGcv(series);
    if (!s.ok()) return s.status();
    const double root = std::sqrt(s->lambda * opt.roughness_scale);
    w.corrected.push_back(m);
    w.rough.push_back(root * d3_basis);
    w.rough0.push_back(root * ThirdDifferences(w.smoothed.col(m)));
  }
  return w;
}

// The recording with the corrections θ = (pose offset, per corrected mode its knots).
Kinematics ShapesAt(const Worm& w, const double* theta) {
  Kinematics k = w.base;
  const int knots = w.knots();
  for (int i = 0; i < w.frames(); ++i) {
    Eigen::VectorXd a = w.smoothed.row(i).transpose();
    for (size_t j = 0; j < w.corrected.size(); ++j)
      a[w.corrected[j]] += w.basis.row(i).dot(Eigen::Map<const Eigen::VectorXd>(theta + 3 + j * knots, knots));
    const Shape q = w.modes.FromModes(a);
    Pose g = w.poses[i];
    if (i == 0) g = {g.x + theta[0], g.y + theta[1], g.q0 + theta[2]};
    k.frames[i].p = LabPoints(g, q, w.lengths[i]);
  }
  return k;
}

// Data residuals (x − r)/σ of every point and frame for each of `count` coefficient
// sets simulated against the recording `k`; false if the drive or a run failed.
bool DataResiduals(const Worm& w, const Kinematics& k, const Coefficients* sets, int count, const SimOptions& sim,
                   SimWorkspace& ws, std::vector<Eigen::VectorXd>* out) {
  auto drive = ShapeDrive::Build(k, w.body, {w.substeps});
  if (!drive.ok()) return false;
  Trajectory traj[kLanes];
  Simulator::SimulateBatch(*drive, sets, count, sim, nullptr, ws, traj);
  out->resize(count);
  for (int s = 0; s < count; ++s) {
    const Trajectory& t = traj[s];
    if (!t.summary.singular.empty() || static_cast<int>(t.poses.size()) != w.frames()) return false;
    Eigen::VectorXd& r = (*out)[s];
    r.resize(w.data_rows());
    for (int i = 0; i < w.frames(); ++i) {
      const Pose& g = t.poses[i];
      const Points x = HeadFramePoints(drive->FrameShape(i), w.body.link_length());
      const double c = std::cos(g.q0), sn = std::sin(g.q0);
      for (int p = 0; p < kNumPoints; ++p) {
        const Vec2 lab(g.x + c * x[p].x() - sn * x[p].y(), g.y + sn * x[p].x() + c * x[p].y());
        const Vec2 d = (w.raw.frames[i].p[p] - lab) / w.sigma;
        r[2 * (kNumPoints * i + p)] = d.x();
        r[2 * (kNumPoints * i + p) + 1] = d.y();
      }
    }
  }
  return true;
}

struct Evaluation {
  std::array<Eigen::VectorXd, 2> rough;  // per worm, the penalty rows stacked
  double f = INFINITY;
};

// The layout of θ: c (4), then per worm its params().
struct Layout {
  int offset[2] = {4, 4};
  int size = 4;
};

Evaluation Evaluate(const std::array<Worm, 2>& worms, const Layout& lay, const Eigen::VectorXd& theta,
                    const SimOptions& sim, SimWorkspace& ws) {
  Evaluation e;
  const Coefficients c{theta[0], theta[1], theta[2], theta[3]};
  double f = 0;
  for (int w = 0; w < 2; ++w) {
    const Worm& wm = worms[w];
    const double* t = theta.data() + lay.offset[w];
    std::vector<Eigen::VectorXd> r;
    if (!DataResiduals(wm, ShapesAt(wm, t), &c, 1, sim, ws, &r)) return e;
    const int knots = wm.knots(), rows = wm.frames() - 3;
    e.rough[w].resize(rows * static_cast<int>(wm.corrected.size()));
    for (size_t j = 0; j < wm.corrected.size(); ++j)
      e.rough[w].segment(j * rows, rows) = wm.rough0[j] +
                                           wm.rough[j] * Eigen::Map<const Eigen::VectorXd>(t + 3 + j * knots, knots);
    f += r[0].squaredNorm() + e.rough[w].squaredNorm();
  }
  e.f = f;
  return e;
}

// Columns 0–3 of a worm's Jacobian (the coefficients, one batch of lanes against the
// shapes `k`) and its residuals r0 at c.
bool CoefficientColumns(const Worm& wm, const Kinematics& k, const Coefficients& c, double step, const SimOptions& sim,
                        Eigen::MatrixXd* j, Eigen::VectorXd* r0) {
  Coefficients sets[5] = {c, c, c, c, c};
  sets[1].mu_n += step, sets[2].mu_t += step, sets[3].eta_n += step, sets[4].eta_t += step;
  SimWorkspace ws;
  std::vector<Eigen::VectorXd> r;
  if (!DataResiduals(wm, k, sets, 5, sim, ws, &r)) return false;
  for (int i = 0; i < 4; ++i) j->col(i) = (r[i + 1] - r[0]) / step;
  *r0 = std::move(r[0]);
  return true;
}

// Columns 4–6 (the start's offset), exact: the whole path moves rigidly with the start,
// turning about the start's head point.
void PoseColumns(const Worm& wm, const double* t, const Eigen::VectorXd& r0, Eigen::MatrixXd* j) {
  const Vec2 pivot(wm.poses[0].x + t[0], wm.poses[0].y + t[1]);
  for (int i = 0; i < wm.frames(); ++i)
    for (int p = 0; p < kNumPoints; ++p) {
      const int row = 2 * (kNumPoints * i + p);
      const Vec2 arm = wm.raw.frames[i].p[p] - wm.sigma * Vec2(r0[row], r0[row + 1]) - pivot;
      (*j)(row, 4) = -1 / wm.sigma, (*j)(row + 1, 4) = 0;
      (*j)(row, 5) = 0, (*j)(row + 1, 5) = -1 / wm.sigma;
      (*j)(row, 6) = arm.y() / wm.sigma, (*j)(row + 1, 6) = -arm.x() / wm.sigma;
    }
}

// Columns 7… (the shape knots) by forward differences, simulated on opt.threads threads.
bool ShapeColumns(const Worm& wm, const double* t, const Coefficients& c, const Eigen::VectorXd& r0,
                  const SimOptions& sim, const ShapeRefitOptions& opt, Eigen::MatrixXd* j) {
  const int np = wm.params(), columns = np - 3;
  std::atomic<bool> failed{false};
  std::vector<SimWorkspace> workspaces(opt.threads);
  ParallelFor(columns, opt.threads, [&](int worker, int64_t col) {
    if (failed) return;
    std::vector<double> tp(t, t + np);
    tp[3 + col] += opt.shape_step;
    std::vector<Eigen::VectorXd> rc;
    if (!DataResiduals(wm, ShapesAt(wm, tp.data()), &c, 1, sim, workspaces[worker], &rc))
      failed = true;
    else
      j->col(7 + col) = (rc[0] - r0) / opt.shape_step;
  });
  return !failed;
}

// The Gauss–Newton normal equations JᵀJ and Jᵀr at θ. A worm's rows touch the
// coefficients and its own block; its roughness rows are linear in its knots.
bool NormalEquations(const std::array<Worm, 2>& worms, const Layout& lay, const Eigen::VectorXd& theta,
                     const Evaluation& at, const SimOptions& sim, const ShapeRefitOptions& opt, Eigen::MatrixXd* jtj,
                     Eigen::VectorXd* jtr) {
  jtj->setZero(lay.size, lay.size);
  jtr->setZero(lay.size);
  const Coefficients c{theta[0], theta[1], theta[2], theta[3]};
  const double step = opt.coefficient_step * theta.head<4>().maxCoeff();
  for (int w = 0; w < 2; ++w) {
    const Worm& wm = worms[w];
    const int np = wm.params(), off = lay.offset[w], knots = wm.knots();
    const double* t = theta.data() + off;
    Eigen::MatrixXd j(wm.data_rows(), 4 + np);
    Eigen::VectorXd r0;
    if (!CoefficientColumns(wm, ShapesAt(wm, t), c, step, sim, &j, &r0)) return false;
    PoseColumns(wm, t, r0, &j);
    if (!ShapeColumns(wm, t, c, r0, sim, opt, &j)) return false;
    std::vector<int> index(4 + np);
    for (int i = 0; i < 4 + np; ++i) index[i] = i < 4 ? i : off + i - 4;
    const Eigen::MatrixXd local = j.transpose() * j;
    const Eigen::VectorXd g = j.transpose() * r0;
    for (int a = 0; a < 4 + np; ++a) {
      (*jtr)[index[a]] += g[a];
      for (int b = 0; b < 4 + np; ++b) (*jtj)(index[a], index[b]) += local(a, b);
    }
    for (size_t m = 0; m < wm.corrected.size(); ++m) {
      const int base = off + 3 + static_cast<int>(m) * knots, rows = static_cast<int>(wm.rough[m].rows());
      jtj->block(base, base, knots, knots) += wm.rough[m].transpose() * wm.rough[m];
      jtr->segment(base, knots) += wm.rough[m].transpose() * at.rough[w].segment(static_cast<int>(m) * rows, rows);
    }
  }
  return true;
}

// The knots that come closest to the shapes of `k` (least squares per corrected mode).
void ProjectShapes(const Worm& wm, const Kinematics& k, double* t) {
  const auto qr = wm.basis.colPivHouseholderQr();
  const Eigen::MatrixXd d = ModeSeries(wm.modes, k) - wm.smoothed;
  for (size_t j = 0; j < wm.corrected.size(); ++j)
    Eigen::Map<Eigen::VectorXd>(t + 3 + j * wm.knots(), wm.knots()) = qr.solve(d.col(wm.corrected[j]));
}

}  // namespace

Result<ShapeRefitResult> RefitWithShapes(const std::array<Kinematics, 2>& raw,
                                         const std::array<Kinematics, 2>& smoothed,
                                         const std::array<double, 2>& noise_mm, const Coefficients& start,
                                         const EvaluationOptions& eval, const ShapeRefitOptions& opt,
                                         const std::array<Kinematics, 2>* start_shapes) {
  if (Status s = opt.Validate(); !s.ok()) return s;
  std::array<Worm, 2> worms;
  Layout lay;
  for (int w = 0; w < 2; ++w) {
    auto wm = PrepareWorm(raw[w], smoothed[w], noise_mm[w], eval, opt, "worm " + std::to_string(w + 1));
    if (!wm.ok()) return wm.status();
    worms[w] = std::move(*wm);
    lay.offset[w] = lay.size;
    lay.size += worms[w].params();
  }
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(lay.size);
  theta.head<4>() << start.mu_n, start.mu_t, start.eta_n, start.eta_t;
  for (int w = 0; w < 2 && start_shapes; ++w) {
    const Kinematics k = (*start_shapes)[w].Truncated(eval.t_max);
    if (static_cast<int>(k.frames.size()) != worms[w].frames())
      return Status::InvalidArgument("shape refit: start shapes differ in frames");
    ProjectShapes(worms[w], k, theta.data() + lay.offset[w]);
  }
  SimWorkspace ws;
  Evaluation at = Evaluate(worms, lay, theta, eval.sim, ws);
  if (!std::isfinite(at.f)) return Status::InvalidArgument("shape refit: the start cannot be simulated");
  ShapeRefitSummary summary;
  summary.initial_f = at.f;
  summary.parameters = lay.size;
  for (int w = 0; w < 2; ++w) summary.shape_modes[w] = static_cast<int>(worms[w].corrected.size());
  summary.termination = "max iterations";
  if (opt.progress) opt.progress(0, at.f, start);
  double damping = 1e-3;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
  for (int it = 0; it < opt.max_iterations; ++it) {
    summary.iterations = it + 1;
    if (!NormalEquations(worms, lay, theta, at, eval.sim, opt, &jtj, &jtr)) {
      summary.termination = "a difference could not be simulated";
      break;
    }
    bool accepted = false;
    for (int attempt = 0; attempt < 8 && !accepted; ++attempt, damping *= 10) {
      Eigen::MatrixXd a = jtj;
      a.diagonal() += damping * jtj.diagonal() + Eigen::VectorXd::Constant(lay.size, 1e-12 * jtj.diagonal().maxCoeff());
      Eigen::VectorXd trial = theta - a.ldlt().solve(jtr);
      for (int i = 0; i < 4; ++i) trial[i] = std::max(trial[i], 0.0);
      Evaluation e = Evaluate(worms, lay, trial, eval.sim, ws);
      if (e.f < at.f) {
        const double gain = at.f - e.f;
        theta = trial, at = std::move(e), accepted = true;
        damping = std::max(damping / 100, 1e-9);
        if (gain < opt.f_tolerance) summary.termination = "converged";
      }
    }
    if (!accepted) summary.termination = "no step lowers F";
    if (opt.progress) opt.progress(it + 1, at.f, {theta[0], theta[1], theta[2], theta[3]});
    if (!accepted || summary.termination == "converged") break;
  }
  summary.final_f = at.f;
  if (NormalEquations(worms, lay, theta, at, eval.sim, opt, &jtj, &jtr)) {
    const int d = lay.size - 4;
    Eigen::LLT<Eigen::MatrixXd> llt(jtj.bottomRightCorner(d, d));
    if (llt.info() == Eigen::Success)
      summary.nuisance_logdet = 2 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  }
  summary.final_roughness = at.rough[0].squaredNorm() + at.rough[1].squaredNorm();
  ShapeRefitResult out;
  out.set = {theta[0], theta[1], theta[2], theta[3]};
  for (int w = 0; w < 2; ++w) out.shapes[w] = ShapesAt(worms[w], theta.data() + lay.offset[w]);
  out.summary = summary;
  return out;
}

}  // namespace wormdrag
