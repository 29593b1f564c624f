#include "tests/testutil/taylor.hh"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace rodmesh::testutil {

std::string TaylorResult::table() const {
  std::ostringstream os;
  os << "observed order " << order << " (" << validPoints << " valid pairs), zeroth order " << zerothOrder
     << ", |dF| " << derivativeNorm << "\n  h            remainder\n";
  for (std::size_t i = 0; i < steps.size(); ++i) os << "  " << steps[i] << "  " << remainders[i] << "\n";
  return os.str();
}

TaylorResult taylorTest(const VectorFn& F, const Eigen::VectorXd& x, const Eigen::VectorXd& d,
                        const Eigen::VectorXd& dF, double h0, int sweeps) {
  TaylorResult r;
  const Eigen::VectorXd F0 = F(x);
  r.derivativeNorm = dF.norm();
  std::vector<double> zeroth;
  for (int k = 0; k < sweeps; ++k) {
    const double h = h0 * std::pow(0.5, k);
    const Eigen::VectorXd Fh = F(x + h * d);
    r.steps.push_back(h);
    r.remainders.push_back((Fh - F0 - h * dF).norm());
    zeroth.push_back((Fh - F0).norm());
  }
  // Round-off floor: a few hundred ulps of |F|, scaled by sqrt(m).
  const double floor = 1e-13 * std::max(F0.norm(), 1e-300) + 1e-300;
  std::vector<double> orders, zorders;
  for (int k = 0; k + 1 < sweeps; ++k) {
    if (r.remainders[k + 1] > 1e3 * floor && r.remainders[k] > 0)
      orders.push_back(std::log2(r.remainders[k] / r.remainders[k + 1]));
    if (zeroth[k + 1] > 1e3 * floor && zeroth[k] > 0) zorders.push_back(std::log2(zeroth[k] / zeroth[k + 1]));
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  r.validPoints = static_cast<int>(orders.size());
  r.order = median(orders);
  r.zerothOrder = median(zorders);
  // An exact linear map leaves only round-off: that is a pass, not a failure.
  if (orders.empty() && !r.remainders.empty()) {
    const double maxRem = *std::max_element(r.remainders.begin(), r.remainders.end());
    const double maxZero = *std::max_element(zeroth.begin(), zeroth.end());
    if (maxZero > 0 && maxRem <= 1e-9 * maxZero) {
      r.order = 2.0;
      r.validPoints = 3;
    }
  }
  return r;
}

TaylorResult taylorTestScalar(const std::function<double(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
                              const Eigen::VectorXd& d, double df, double h0, int sweeps) {
  VectorFn F = [&](const Eigen::VectorXd& y) { return Eigen::VectorXd::Constant(1, f(y)); };
  return taylorTest(F, x, d, Eigen::VectorXd::Constant(1, df), h0, sweeps);
}

std::string findBadComponent(const VectorFn& F, const Eigen::VectorXd& x,
                             const std::function<Eigen::VectorXd(int)>& claimedColumn, double h) {
  double worst = -1.0;
  std::ostringstream os;
  for (int j = 0; j < x.size(); ++j) {
    Eigen::VectorXd xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    const Eigen::VectorXd fd = (F(xp) - F(xm)) / (2 * h);
    const Eigen::VectorXd c = claimedColumn(j);
    for (int i = 0; i < fd.size(); ++i) {
      const double err = std::abs(fd[i] - c[i]) / (1e-8 + std::abs(fd[i]) + std::abs(c[i]));
      if (err > worst) {
        worst = err;
        os.str("");
        os << "row " << i << ", column " << j << ": claimed " << c[i] << ", finite difference " << fd[i];
      }
    }
  }
  return os.str();
}

testing::AssertionResult taylorCheck(const TaylorResult& r, double minOrder) {
  if (r.derivativeNorm == 0.0) return testing::AssertionFailure() << "derivative is zero: the test would be vacuous";
  if (r.validPoints < 3) return testing::AssertionFailure() << "too few steps above round-off\n" << r.table();
  if (r.order < minOrder) return testing::AssertionFailure() << "order below " << minOrder << "\n" << r.table();
  return testing::AssertionSuccess();
}

}  // namespace rodmesh::testutil
