// Phases 1 and 2: the grid, the refinement around the kept sets, the d1/d2 selection,
// and the order the screening passes evaluate sets in (exact early abandoning).
#include "core/estimate/search.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

namespace wormdrag {

Status SearchOptions::Validate() const {
  if (n_max < 1) return Status::InvalidArgument("N_max must be >= 1");
  if (!(d_mu > 0) || !(d_eta > 0) || !std::isfinite(d_mu) || !std::isfinite(d_eta))
    return Status::InvalidArgument("the grid steps d_mu and d_eta must be positive numbers");
  if (!(d1 > 0 && d1 <= 100)) return Status::InvalidArgument("d1 must be a percentage in (0, 100]");
  if (!(d2 > 0 && d2 <= 100)) return Status::InvalidArgument("d2 must be a percentage in (0, 100]");
  const double grid = std::pow(n_max + 1.0, 4);
  if (grid > static_cast<double>(max_sets))
    return Status::ResourceExhausted("N_max = " + std::to_string(n_max) + " gives " + std::to_string(int64_t(grid)) +
                                     " Phase 1 sets, more than the limit of " + std::to_string(max_sets));
  return Status::Ok();
}

std::vector<Coefficients> GridSets(const SearchOptions& o) {
  std::vector<Coefficients> sets;
  const int m = o.n_max + 1;
  sets.reserve(static_cast<size_t>(m) * m * m * m);
  const double hm = o.d_mu / 2, he = o.d_eta / 2;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      for (int c = 0; c < m; ++c)
        for (int d = 0; d < m; ++d) sets.push_back({(2 * a) * hm, (2 * b) * hm, (2 * c) * he, (2 * d) * he});
  return sets;
}

std::vector<Coefficients> RefinementSets(const std::vector<ScoredSet>& kept, const SearchOptions& o) {
  const double hm = o.d_mu / 2, he = o.d_eta / 2;
  std::set<std::array<long, 4>> seen;
  std::vector<Coefficients> out;
  for (const ScoredSet& k : kept) {
    const long c[4] = {std::lround(k.set.mu_n / hm), std::lround(k.set.mu_t / hm), std::lround(k.set.eta_n / he),
                       std::lround(k.set.eta_t / he)};
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int e = -1; e <= 1; ++e)
          for (int f = -1; f <= 1; ++f) {
            const std::array<long, 4> u = {c[0] + a, c[1] + b, c[2] + e, c[3] + f};
            if (u[0] < 0 || u[1] < 0 || u[2] < 0 || u[3] < 0) continue;
            if (!seen.insert(u).second) continue;
            out.push_back({u[0] * hm, u[1] * hm, u[2] * he, u[3] * he});
          }
  }
  return out;
}

int64_t KeepCount(size_t sets, double percent) {
  return std::max<int64_t>(1, std::llround(percent / 100.0 * static_cast<double>(sets)));
}

std::vector<ScoredSet> SelectBest(const std::vector<Coefficients>& sets, const std::vector<double>& e, double percent) {
  std::vector<size_t> idx;
  for (size_t i = 0; i < sets.size(); ++i)
    if (std::isfinite(e[i])) idx.push_back(i);
  const size_t want = static_cast<size_t>(KeepCount(sets.size(), percent));
  const size_t keep = std::min(want, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + keep, idx.end(),
                    [&](size_t a, size_t b) { return e[a] < e[b] || (e[a] == e[b] && a < b); });
  std::vector<ScoredSet> out;
  for (size_t i = 0; i < keep; ++i) out.push_back({sets[idx[i]], e[idx[i]]});
  return out;
}

std::vector<size_t> CoarseGridPass(const SearchOptions& o) {
  const size_t m = static_cast<size_t>(o.n_max) + 1;
  std::vector<size_t> out;
  for (size_t a = 0; a < m; a += 2)
    for (size_t b = 0; b < m; b += 2)
      for (size_t c = 0; c < m; c += 2)
        for (size_t d = 0; d < m; d += 2) out.push_back(((a * m + b) * m + c) * m + d);
  return out;
}

std::vector<size_t> FineGridPass(const SearchOptions& o, const std::vector<double>& e, int64_t keep) {
  const int m = o.n_max + 1;
  const std::vector<size_t> coarse = CoarseGridPass(o);
  // The cap: the keep-th smallest coarse E. Every abandoned coarse set lies above it
  // (it lost to a cut no lower), so min(E, cap) is known exactly for every corner.
  std::vector<double> known;
  for (size_t i : coarse)
    if (std::isfinite(e[i])) known.push_back(e[i]);
  double cap = std::numeric_limits<double>::infinity();
  if (keep >= 1 && static_cast<int64_t>(known.size()) >= keep) {
    std::nth_element(known.begin(), known.begin() + (keep - 1), known.end());
    cap = known[keep - 1];
  }
  auto capped = [&](size_t i) { return std::isfinite(e[i]) && e[i] < cap ? e[i] : cap; };
  // The coarse values a grid index lies between: itself if even, else its two neighbours.
  auto corners = [&](int n, int* out) {
    if (n % 2 == 0) {
      out[0] = n;
      return 1;
    }
    int k = 0;
    out[k++] = n - 1;
    if (n + 1 < m) out[k++] = n + 1;
    return k;
  };
  std::vector<std::pair<double, size_t>> ranked;
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      for (int c = 0; c < m; ++c)
        for (int d = 0; d < m; ++d) {
          if (a % 2 == 0 && b % 2 == 0 && c % 2 == 0 && d % 2 == 0) continue;
          int ca[2], cb[2], cc[2], cd[2];
          const int na = corners(a, ca), nb = corners(b, cb), nc = corners(c, cc), nd = corners(d, cd);
          double sum = 0;
          for (int i = 0; i < na; ++i)
            for (int j = 0; j < nb; ++j)
              for (int k = 0; k < nc; ++k)
                for (int l = 0; l < nd; ++l) sum += capped(((size_t(ca[i]) * m + cb[j]) * m + cc[k]) * m + cd[l]);
          ranked.push_back({sum / (na * nb * nc * nd), ((size_t(a) * m + b) * m + c) * m + d});
        }
  std::sort(ranked.begin(), ranked.end());  // ties: grid order
  std::vector<size_t> out;
  out.reserve(ranked.size());
  for (const auto& r : ranked) out.push_back(r.second);
  return out;
}

std::vector<size_t> RefinementPass(const std::vector<Coefficients>& refined, const std::vector<ScoredSet>& kept) {
  std::map<std::array<double, 4>, size_t> where;
  for (size_t i = 0; i < refined.size(); ++i) where.emplace(refined[i].AsArray(), i);
  std::vector<size_t> out;
  std::vector<bool> listed(refined.size(), false);
  for (const ScoredSet& k : kept) {
    auto it = where.find(k.set.AsArray());
    if (it == where.end() || listed[it->second]) continue;
    out.push_back(it->second);
    listed[it->second] = true;
  }
  for (size_t i = 0; i < refined.size(); ++i)
    if (!listed[i]) out.push_back(i);
  return out;
}

namespace {

ScreeningPass InSetOrder() {
  return [](const std::vector<double>& e) {
    std::vector<size_t> idx(e.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    return idx;
  };
}

}  // namespace

std::vector<ScreeningPass> Phase1Passes(const SearchOptions& o) {
  if (!o.abandon) return {InSetOrder()};
  const size_t m = static_cast<size_t>(o.n_max) + 1;
  const int64_t keep = KeepCount(m * m * m * m, o.d1);
  return {[o](const std::vector<double>&) { return CoarseGridPass(o); },
          [o, keep](const std::vector<double>& e) { return FineGridPass(o, e, keep); }};
}

std::vector<ScreeningPass> Phase2Passes(const SearchOptions& o, const std::vector<Coefficients>& refined,
                                        const std::vector<ScoredSet>& kept) {
  if (!o.abandon) return {InSetOrder()};
  return {[&refined, &kept](const std::vector<double>&) { return RefinementPass(refined, kept); }};
}

std::string PhaseSummary::KnotsReport() const {
  if (knots_full <= 0) return "";
  char buf[160];
  std::snprintf(buf, sizeof buf, "%lld abandoned, %.3g of %.3g knots simulated (%.1f %%)",
                static_cast<long long>(abandoned), static_cast<double>(knots), static_cast<double>(knots_full),
                100.0 * static_cast<double>(knots) / static_cast<double>(knots_full));
  return buf;
}

std::string PhaseSummary::OneLineReport() const {
  char buf[600];
  const std::string k = KnotsReport();
  std::snprintf(buf, sizeof buf, "%s: %lld sets (%lld singular%s%s) in %.1f s, best E %.6g mm at (%s)%s%s",
                name.c_str(), static_cast<long long>(sets), static_cast<long long>(singular), k.empty() ? "" : ", ",
                k.c_str(), seconds, best.e, best.set.ToString().c_str(), termination.empty() ? "" : ", ",
                termination.c_str());
  return buf;
}

}  // namespace wormdrag
