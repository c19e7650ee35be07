#include "core/filter/shape_modes.h"

#include <Eigen/Eigenvalues>

#include "core/model/body.h"

namespace wormdrag {

Eigen::VectorXd ShapeModes::ToModes(const Shape& q) const {
  return to_modes * (Eigen::Map<const Eigen::VectorXd>(q.data(), kNumJoints) - mean);
}

Shape ShapeModes::FromModes(const Eigen::VectorXd& a) const {
  const Eigen::VectorXd v = mean + from_modes * a;
  Shape q;
  for (int j = 0; j < kNumJoints; ++j) q[j] = v[j];
  return q;
}
void UnwrappedShapes(const Kinematics& k, int start, int end, std::vector<Shape>* q) {
  q->resize(end - start);
  for (int i = 0; i < end - start; ++i) (*q)[i] = ShapeOf(k.frames[start + i].p);
  for (size_t i = 1; i < q->size(); ++i)
    for (int j = 0; j < kNumJoints; ++j) (*q)[i][j] = (*q)[i - 1][j] + WrapAngle((*q)[i][j] - (*q)[i - 1][j]);
}

namespace {

// The joint angles of each run of valid frames, unwrapped over time.
std::vector<std::vector<Eigen::VectorXd>> UnwrappedRuns(const Kinematics& k) {
  std::vector<std::vector<Eigen::VectorXd>> runs;
  const int n = static_cast<int>(k.frames.size());
  std::vector<Shape> q;
  for (int start = 0; start < n;) {
    if (!k.frames[start].valid) {
      ++start;
      continue;
    }
    int end = start;
    while (end < n && k.frames[end].valid) ++end;
    UnwrappedShapes(k, start, end, &q);
    std::vector<Eigen::VectorXd> run;
    for (const Shape& s : q) run.push_back(Eigen::Map<const Eigen::VectorXd>(s.data(), kNumJoints));
    runs.push_back(std::move(run));
    start = end;
  }
  return runs;
}

}  // namespace

Result<ShapeModes> NoiseWhitenedModes(const Kinematics& k) {
  constexpr int J = kNumJoints;
  const auto runs = UnwrappedRuns(k);
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(J);
  int64_t frames = 0, differences = 0;
  for (const auto& run : runs)
    for (const auto& q : run) {
      mean += q;
      ++frames;
    }
  Eigen::MatrixXd noise = Eigen::MatrixXd::Zero(J, J), shape = Eigen::MatrixXd::Zero(J, J);
  for (const auto& run : runs) {
    for (const auto& q : run) shape += (q - mean / frames) * (q - mean / frames).transpose();
    for (size_t i = 3; i < run.size(); ++i) {
      const Eigen::VectorXd d3 = run[i] - 3 * run[i - 1] + 3 * run[i - 2] - run[i - 3];
      noise += d3 * d3.transpose();
      ++differences;
    }
  }
  if (differences < 4 * (J + 1) || frames < 4 * (J + 1))
    return Status::InvalidArgument("too few consecutive valid frames to separate shape from noise");
  mean /= frames;
  shape /= frames;
  noise /= 20.0 * differences;
  // A floor keeps the noise covariance positive definite on exact data (rounding only).
  noise.diagonal().array() += 1e-14 + 1e-9 * noise.trace() / J;
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(shape, noise);
  if (eig.info() != Eigen::Success) return Status::Internal("shape modes: eigen decomposition failed");
  // Vᵀ N V = I, so a = Vᵀ(q − mean) has unit white noise and q − mean = N V a.
  ShapeModes m;
  m.mean = mean;
  m.to_modes = eig.eigenvectors().transpose();
  m.from_modes = noise * eig.eigenvectors();
  m.snr = eig.eigenvalues();
  return m;
}

}  // namespace wormdrag
