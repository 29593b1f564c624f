#include "solver/stability.hh"

#include "model/pose_system.hh"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <stdexcept>

namespace rodmesh {

std::vector<int> groupedMinimumDegreeOrder(const Eigen::SparseMatrix<double>& pattern, const std::vector<int>& group,
                                           int groups) {
  const int n = static_cast<int>(pattern.cols());
  if (pattern.rows() != n || static_cast<int>(group.size()) != n)
    throw std::invalid_argument("groupedMinimumDegreeOrder: sizes do not match");
  // Graph of the groups: an edge wherever two groups share a non-zero.
  std::vector<Eigen::Triplet<double>> links;
  links.reserve(static_cast<std::size_t>(pattern.nonZeros()) + groups);
  for (int g = 0; g < groups; ++g) links.emplace_back(g, g, 1.0);
  for (int c = 0; c < n; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(pattern, c); it; ++it) {
      const int a = group[it.row()], b = group[c];
      if (a != b) links.emplace_back(std::max(a, b), std::min(a, b), 1.0);
    }
  Eigen::SparseMatrix<double> graph(groups, groups);
  graph.setFromTriplets(links.begin(), links.end());  // duplicates summed: pattern only
  Eigen::SparseMatrix<double> full = graph.selfadjointView<Eigen::Lower>();
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> perm;
  Eigen::AMDOrdering<int>()(full, perm);  // perm.indices()[k]: group eliminated k-th
  // Unknowns of the k-th group follow those of the groups before it.
  std::vector<int> rank(groups);  // rank[g]: when group g is eliminated
  for (int k = 0; k < groups; ++k) rank[perm.indices()[k]] = k;
  std::vector<int> first(groups + 1, 0);  // first[k]: new position of the first unknown of the k-th group
  for (int i = 0; i < n; ++i) first[rank[group[i]] + 1]++;
  for (int k = 0; k < groups; ++k) first[k + 1] += first[k];
  std::vector<int> next(first.begin(), first.end() - 1);
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = next[rank[group[i]]]++;
  return order;
}

bool outOfPlaneStable(const Scene& scene, const RodNetwork& network, const EffectSet& planarEffects, int pose,
                      const Design& design, const std::vector<Vec3>& positions) {
  const PoseSystem sys(scene, network, spatialVariant(planarEffects), pose);
  const int n = sys.numDofs();
  if (n == 0) return true;
  // Zero twists measured in the charts of the scene's rest frames, under the
  // full load.
  const PoseState state{sys.dofsFrom(positions, Eigen::VectorXd::Zero(network.numEdges())),
                        sys.restCharts(Design::fromScene(scene)), 1.0, {}};
  Eigen::VectorXd g;
  Eigen::SparseMatrix<double> H;  // lower triangle
  sys.evaluate(state, design, &g, &H);

  // Order by vertices: a vertex's coordinates with the twists of the edges
  // that start at it (AMD on the ~n/4 vertices instead of the n unknowns).
  std::vector<int> group(n, -1);
  for (int v = 0; v < network.numVertices(); ++v)
    for (int k = 0, d = sys.vertexDof()[v]; d >= 0 && k < sys.dofsPerVertex(); ++k) group[d + k] = v;
  for (int edge = 0; edge < network.numEdges(); ++edge) group[sys.thetaDof(edge)] = network.edges()[edge].a;
  const std::vector<int> order = groupedMinimumDegreeOrder(H, group, network.numVertices());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> P(n);
  for (int i = 0; i < n; ++i) P.indices()[i] = order[i];
  Eigen::SparseMatrix<double> Hp(n, n);
  Hp.selfadjointView<Eigen::Lower>() = H.selfadjointView<Eigen::Lower>().twistedBy(P);

  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt(Hp);
  if (ldlt.info() != Eigen::Success) return true;  // cannot tell; do not cry wolf
  const Eigen::VectorXd D = ldlt.vectorD();
  const double tol = 1e-8 * D.cwiseAbs().maxCoeff();
  return (D.array() >= -tol).all();
}

}  // namespace rodmesh
