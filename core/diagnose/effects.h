// Unmodelled effects of the sim-to-real gap (docs/conventions.md §5). The catalogue's names and
// definitions are binding; EffectParams is a constant description (like Coefficients)
// of which effects act and with what parameters. Every parameter's neutral value gives
// back the base model of docs/conventions.md §1–2 exactly.
//
// Catalogue (binding):
//   body_gradient      every coefficient of link k scaled by 1 + a (s_k − ½), s_k = (k − ½)/N     a
//   time_drift         (μ_n, η_n) scaled by 1 + a (t/T − ½) over the analysed span T               a
//   power_law          f_d = −(μ_d + η_d v_ref) sgnε(v_d) |v_d / v_ref|^n, v_ref = 0.1 mm/s       n
//   stiction           Coulomb coefficients μ_d (1 + a e^{−(v_d/v_s)²}), v_s = 0.02 mm/s           a
//   lag                the body's velocity at t follows the joint angles and rates at t − δ       δ (s)
//   flow               friction acts on the velocity relative to a medium moving at (w_x, w_y)    w_x, w_y (mm/s)
//   gap_offset         across each run of missing frames the recorded body is displaced by
//                      (1 + a) × the model's displacement over the gap (measurement artefact)    a
//   lateral_asymmetry  normal Coulomb μ_n (1 + a w), w = ½ (1 + sgnε(v_n))                         a
//
// Out of the catalogue (for testing the `unexplained` verdict; never fitted):
//   stretch            the body length oscillates, L(t) = L (1 + A sin(2π f_s t)), f_s = 1.3 Hz   A
//   tether             an elastic force −k (c(t) − c(0)) pulls the body's centroid back to where
//                      it started (a body held in its own track), applied at the centroid        k (µN/mm)
//   boundary           the plate changes at the line x = x_b through the body's starting
//                      centroid: every coefficient of a link is × (1 + A σ((x_k − x_b)/w)), x_k
//                      the link's midpoint in the lab, σ the logistic step, w = 0.05 mm         A
//
// gap_offset's displacement is the model's translation of the body's centroid (mean of
// the 14 points) from the last valid frame before the gap to the first one after it; the
// extra a × that displacement is added to every later frame (it accumulates over gaps).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/common/json.h"
#include "core/common/status.h"

namespace wormdrag::diagnose {

inline constexpr double kPowerLawVRef = 0.1;    // mm/s
inline constexpr double kStictionVs = 0.02;     // mm/s
inline constexpr double kStretchHz = 1.3;       // Hz
inline constexpr double kBoundaryWidth = 0.05;  // mm, the boundary's logistic width

enum class Effect {
  kBodyGradient,
  kTimeDrift,
  kPowerLaw,
  kStiction,
  kLag,
  kFlow,
  kGapOffset,
  kLateralAsymmetry,
  kStretch,  // out of catalogue from here on
  kTether,
  kBoundary,
};
inline constexpr int kNumCatalogue = 8;
inline constexpr int kNumEffects = 11;

struct EffectParams {
  double body_gradient = 0;       // a
  double time_drift = 0;          // a
  bool power_law = false;         // the affine law is replaced by the power law (n below)
  double power_n = 1;             // n
  double stiction = 0;            // a
  double lag = 0;                 // δ, s
  double flow_x = 0, flow_y = 0;  // w, mm/s (lab frame)
  double gap_offset = 0;          // a
  double lateral_asymmetry = 0;   // a
  double stretch = 0;             // A (relative)
  double tether = 0;              // k, µN/mm
  double boundary = 0;            // A
  bool IsNeutral() const;
  bool Has(Effect e) const;  // the effect acts (non-neutral)
  // The friction law differs from the base one (needs the effect solver per term).
  bool ChangesLaw() const { return power_law || stiction != 0 || lateral_asymmetry != 0; }
  std::string ToString() const;  // "body_gradient=0.5,flow=0.01,0" ("none" when neutral)
  Json ToJson() const;           // {"flow": {"w_x": 0.01, "w_y": 0}, …}: the acting effects
};

// Static description of one effect for the fits.
struct EffectInfo {
  Effect effect;
  const char* name;  // binding catalogue name
  bool in_catalogue;
  std::vector<const char*> params;   // parameter names
  std::vector<double> neutral;       // neutral values (power_law: the n at which the fit starts)
  std::vector<double> lower, upper;  // admissible range in a fit
  std::vector<double> unit;          // one "grid unit" of the fit's variables
  const char* units;                 // of the parameter(s)
};

const std::vector<EffectInfo>& AllEffects();  // catalogue first, then the out-of-catalogue ones
const EffectInfo& InfoOf(Effect e);
Result<Effect> ParseEffectName(const std::string& name);

// Reads / writes the parameters of effect e in p (power_law: setting switches it on).
std::vector<double> GetParams(const EffectParams& p, Effect e);
void SetParams(EffectParams* p, Effect e, const std::vector<double>& values);

// Parses "NAME=V[,V2][;NAME=V…]" (';' or repeated --effect flags separate effects;
// flow takes two values). "none" gives the neutral set.
Result<EffectParams> ParseEffects(const std::vector<std::string>& items);

// Link multiplier of body_gradient for link k = 1 … N.
double BodyGradientFactor(double a, int link);
// Per-term force law with effects: the resistive force magnitude f(v) (friction is −f)
// and its derivative, for coefficients (μ, η) already scaled by body_gradient/time_drift.
// `normal` selects the lateral asymmetry (normal terms only).
void EffectForce(double v, double mu, double eta, bool normal, const EffectParams& p, double eps, double* f,
                 double* dfdv);

}  // namespace wormdrag::diagnose
