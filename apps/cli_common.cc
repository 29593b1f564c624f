#include "apps/cli_common.hh"

#include "solver/bfgs.hh"
#include "solver/equilibrium.hh"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <cerrno>
#include <climits>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

namespace rodmesh::cli {

void checkOutputPath(const std::string& path, const std::string& flag, const std::vector<std::string>& inputs) {
  auto bad = [&](const std::string& why) { throw InputError(flag + " " + printableText(path, 100) + ": " + why); };
  if (path.empty()) throw InputError(flag + ": output path is empty");
  if (path.find('\0') != std::string::npos) bad("the path contains a NUL byte");
  if (path.back() == '/') bad("names a directory, not a file");
  const std::size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  const std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  if (base == "." || base == "..") bad("names a directory, not a file");
  if (path.size() >= PATH_MAX) bad("the path is " + std::to_string(path.size()) + " bytes long; at most " +
                                   std::to_string(PATH_MAX - 1) + " are allowed");
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) bad("is a directory, not a file");
    if (!S_ISREG(st.st_mode)) bad("exists and is not a regular file (a device, FIFO or socket); not replaced");
    for (const std::string& in : inputs) {
      std::error_code ec;
      if (!in.empty() && std::filesystem::equivalent(path, in, ec) && !ec)
        bad("is the input file " + printableText(in, 100) + "; writing the result would replace it");
    }
  }
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    bad("directory " + printableText(dir, 100) + " does not exist or is not a directory");
  if (access(dir.c_str(), W_OK) != 0) bad("directory " + printableText(dir, 100) + " does not exist or is not writable");
  // Every component must fit the file system's name limit, the file name
  // with the writer's temporary suffix ".tmp.PID" (io/archive.hh) too.
  long nameMax = ::pathconf(dir.c_str(), _PC_NAME_MAX);
  if (nameMax <= 0) nameMax = NAME_MAX;
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const std::string tmpBase = tmp.substr(slash == std::string::npos ? 0 : slash + 1);
  if (tmpBase.size() > static_cast<std::size_t>(nameMax))
    bad("the file name is " + std::to_string(base.size()) + " bytes long; the file system allows " +
        std::to_string(nameMax) + " bytes per name, " + std::to_string(tmpBase.size() - base.size()) +
        " of them taken by the temporary suffix \".tmp.PID\" while writing");
  for (std::size_t b = 0; b < dir.size();) {
    std::size_t e = dir.find('/', b);
    if (e == std::string::npos) e = dir.size();
    if (e - b > static_cast<std::size_t>(nameMax))
      bad("a directory name in the path is " + std::to_string(e - b) + " bytes long; the file system allows " +
          std::to_string(nameMax));
    b = e + 1;
  }
  // Whether a file can be made there at all (e.g. /proc is "writable" to
  // root by its mode bits): an unnamed file, as the archive writer makes
  // first, else a named one removed at once.
#ifdef O_TMPFILE
  const int probe = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0600);
  if (probe >= 0) {
    ::close(probe);
    return;
  }
#endif
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) bad("cannot create a file in directory " + printableText(dir, 100) + " (" + std::strerror(errno) + ")");
  ::close(fd);
  ::unlink(tmp.c_str());
}

void checkOptimizeMemory(const Scene& scene, const DesignSpace& space, bool reduced) {
  if (!reduced) return;
  DesignPhase all;
  all.level = space.numLevels() - 1;
  all.radii = scene.design.radii;
  all.restShape = scene.design.restShape;
  const double n = space.numFree(all);
  if (n > BfgsOptions().denseLimit) return;  // limited-memory BFGS: O(n) storage
  const double bytes = 8.0 * n * n;
  double available = static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGESIZE));
  struct rlimit rl;
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
    available = std::min(available, static_cast<double>(rl.rlim_cur));
  if (!(available > 0) || bytes <= 0.5 * available) return;
  char why[320];
  std::snprintf(why, sizeof why,
                "design.control_points_per_rod: %d control points per rod give %.0f design values; --method "
                "reduced's BFGS matrix of them needs %.1f GiB, more than half of the %.1f GiB of memory available "
                "(use fewer control points or --method sand), got %d",
                scene.design.controlPointsPerRod, n, bytes / (1u << 30), available / (1u << 30),
                scene.design.controlPointsPerRod);
  throw InputError(scene.sourcePath + ": " + why);
}

void describeModel(Archive& a, const RodNetwork& net, const EffectSet& fx, long long dofsPerPose) {
  a.effects = fx.list();
  a.effectsReason = fx.explain();
  a.planar = fx.planar ? 1 : 0;
  a.dofsPerPose = dofsPerPose;
  a.nVertices = net.numVertices();
  a.nEdges = net.numEdges();
  a.nRods = net.numRods();
  a.nConnections = net.numConnections();
}

void printEffects(const EffectSet& fx, const RodNetwork& net, long long dofsPerPose) {
  std::cerr << "model: " << net.numVertices() << " vertices, " << net.numEdges() << " edges, " << net.numRods()
            << " rods, " << net.numConnections() << " connections; normals " << net.normalSource() << "\n";
  std::cerr << "simulated effects: " << fx.list() << "\n";
  for (int k = 0; k < kEffectCount; ++k)
    std::cerr << "  " << effectName(static_cast<Effect>(k)) << ": " << (fx.on[k] ? "on " : "off") << "  (" << fx.reason[k]
              << ")\n";
  std::cerr << "  unknowns: " << dofsPerPose << " per pose, "
            << (fx.planar ? "in-plane (2 per free vertex, no twist)" : "3D") << "  (" << fx.planarReason << ")\n";
}

MatX3 toRows(const std::vector<Vec3>& v) {
  MatX3 m(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.row(i) = v[i].transpose();
  return m;
}

MatX2 toRows(const std::vector<Vec2>& v) {
  MatX2 m(static_cast<Eigen::Index>(v.size()), 2);
  for (std::size_t i = 0; i < v.size(); ++i) m.row(i) = v[i].transpose();
  return m;
}

void setRestAndRadii(Archive& a, const std::vector<Vec3>& rest, const std::vector<Vec2>& radii) {
  a.restPositions = toRows(rest);
  a.radii = toRows(radii);
}

ArchivePose makeArchivePose(const std::string& name, const std::vector<Vec3>& positions, const Eigen::VectorXd* twist,
                            const std::vector<Vec3>& target, const PoseSolveSummary& solve) {
  ArchivePose p;
  p.name = name;
  p.positions = toRows(positions);
  if (twist) p.twist = *twist;
  if (!target.empty()) {
    if (target.size() != positions.size())
      throw std::invalid_argument("pose " + name + ": " + std::to_string(target.size()) + " target positions for " +
                                  std::to_string(positions.size()) + " vertices");
    p.target = toRows(target);
    p.rmsError = rmsError(positions, target);
  }
  if (solve.solve) {
    p.residualNorm = solve.solve->residualNorm;
    p.status = archiveStatus(solve.solve->outcome);
    p.iterations = solve.solve->iterations;
    p.timeSeconds = solve.solve->timeSeconds;
  }
  p.outOfPlaneStable = solve.outOfPlaneStable;
  p.stable = solve.stable;
  p.smallestEigenvalue = solve.smallestEigenvalue;
  p.unloadedSmallestEigenvalue = solve.unloadedSmallestEigenvalue;
  p.criticalPoints = solve.criticalPoints;
  p.imperfectionSensitive = solve.imperfectionSensitive;
  p.imperfectionGap = solve.imperfectionGap;
  return p;
}

void setOptimizeResult(ArchivePose& p, const std::vector<Vec3>& initialPositions,
                       const std::vector<Vec3>& optimizerPositions) {
  if (static_cast<Eigen::Index>(initialPositions.size()) != p.positions.rows() ||
      static_cast<Eigen::Index>(optimizerPositions.size()) != p.positions.rows())
    throw std::invalid_argument("pose " + p.name + ": initial or optimizer positions do not match the vertex count");
  p.initialPositions = toRows(initialPositions);
  double gap = 0.0;
  for (std::size_t v = 0; v < optimizerPositions.size(); ++v)
    gap = std::max(gap, (p.positions.row(v) - optimizerPositions[v].transpose()).norm());
  p.equilibriumGap = gap;
}

std::optional<double> overallRmsError(const Archive& a) {
  double sum = 0.0;
  Eigen::Index count = 0;
  for (const ArchivePose& p : a.poses) {
    if (p.target.rows() == 0 || p.target.rows() != p.positions.rows()) return std::nullopt;
    sum += (p.positions - p.target).squaredNorm();
    count += p.positions.rows();
  }
  if (count == 0) return std::nullopt;
  return std::sqrt(sum / static_cast<double>(count));
}

std::string formatSeconds(double s) {
  char buf[32];
  if (s < 1.0) std::snprintf(buf, sizeof buf, "%.1f ms", s * 1e3);
  else std::snprintf(buf, sizeof buf, "%.2f s", s);
  return buf;
}

std::string criticalPointNote(const PoseResult& p) {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "pose '%s' is at a critical point of its loading path (smallest stiffness eigenvalue %.3g N/m, "
                "%.2g of the unloaded structure's): a little more load or a small imperfection makes it snap or "
                "buckle to another equilibrium",
                p.name.c_str(), p.smallestEigenvalue.value_or(0.0),
                p.smallestEigenvalue.value_or(0.0) / p.unloadedSmallestEigenvalue.value_or(1.0));
  return buf;
}

std::string imperfectionNote(const PoseResult& p) {
  char buf[480];
  if (!std::isfinite(p.imperfectionGap.value_or(0.0)))
    std::snprintf(buf, sizeof buf,
                  "pose '%s' is imperfection-sensitive: with every radius changed by %.2g%% (either way) its loading "
                  "path does not reach an equilibrium; a printed object, whose radii are never exact, may not reach "
                  "the designed pose",
                  p.name.c_str(), 100 * kImperfectionRadiusChange);
  else
    std::snprintf(buf, sizeof buf,
                  "pose '%s' is imperfection-sensitive: with every radius changed by %.2g%% (either way) its loading "
                  "path reaches an equilibrium up to %.4g mm away (largest displacement from rest %.4g mm); a printed "
                  "object, whose radii are never exact, may reach another equilibrium than the designed one",
                  p.name.c_str(), 100 * kImperfectionRadiusChange, *p.imperfectionGap * 1e3,
                  p.largestDisplacement.value_or(0.0) * 1e3);
  return buf;
}

PoseSolveSummary newtonSolveSummary(const PoseResult& pr) {
  PoseSolveSummary sum;
  sum.solve = pr.report;
  if (pr.outOfPlaneStable) sum.outOfPlaneStable = *pr.outOfPlaneStable ? 1 : 0;
  if (pr.stable) sum.stable = *pr.stable ? 1 : 0;
  sum.smallestEigenvalue = pr.smallestEigenvalue;
  sum.unloadedSmallestEigenvalue = pr.unloadedSmallestEigenvalue;
  if (pr.imperfectionGap) {
    sum.imperfectionSensitive = pr.imperfectionSensitive() ? 1 : 0;
    if (std::isfinite(*pr.imperfectionGap)) sum.imperfectionGap = pr.imperfectionGap;
  }
  const auto& cps = pr.report.criticalPoints;
  sum.criticalPoints.resize(static_cast<Eigen::Index>(cps.size()), 3);
  for (std::size_t k = 0; k < cps.size(); ++k)
    sum.criticalPoints.row(static_cast<Eigen::Index>(k)) << cps[k].loadFactor, cps[k].smallestEigenvalue, cps[k].jump;
  return sum;
}

Archive optimizeArchive(const Scene& scene, const SceneModel& model, const DesignSpace& space,
                        const DesignOptimizerResult& r, const ArchivedDesign& chosen, const std::string& method) {
  const Design& design = chosen.design;
  Archive a;
  a.command = "optimize";
  a.sceneJson = scene.sourceText;
  describeModel(a, model.network(), model.effects(), model.numPoses() > 0 ? model.pose(0).numDofs() : 0);
  setRestAndRadii(a, design.restPositions, design.radii);
  a.initialRadii = toRows(space.toDesign(space.initialControls(scene)).radii);
  for (int p = 0; p < model.numPoses(); ++p) {
    const PoseResult& pr = chosen.simulation.poses[p];
    ArchivePose ap = makeArchivePose(pr.name, pr.positions, model.effects().has(Effect::Twist) ? &pr.twist : nullptr,
                                     scene.poses[p].target, newtonSolveSummary(pr));
    // The optimizer's own equilibria exist for its final design only; a
    // fallback design's are not kept, and neither is its gap. Without
    // equilibria of the initial design (the run failed before them), the
    // re-solved positions stand in.
    std::vector<Vec3> own = pr.positions;
    if (!chosen.fallback && p < static_cast<int>(r.states.size()) &&
        r.states[p].u.size() == model.pose(p).numDofs()) {
      own = model.pose(p).positions(r.states[p], design);
    }
    setOptimizeResult(ap, r.initialPositions.size() > static_cast<std::size_t>(p) ? r.initialPositions[p] : pr.positions,
                      own);
    if (chosen.fallback || chosen.outOfPlane) ap.equilibriumGap.reset();
    a.poses.push_back(std::move(ap));
  }
  ArchiveHistory h;
  for (const DesignIterate& it : r.history) {
    h.iteration.push_back(it.iteration);
    h.timeSeconds.push_back(it.elapsed);
    h.objective.push_back(it.objective);
    h.rmsError.push_back(it.rms);
    h.level.push_back(it.level);
    h.constraintViolation.push_back(it.constraintViolation);
    h.gradientNorm.push_back(it.gradientNorm);
    h.phase.push_back(it.phase);
    h.confirmedRms.push_back(it.confirmedRms);
  }
  if (method == "newton")
    for (const DesignIterate& it : r.history) {
      h.cgIterations.push_back(it.cgIterations);
      h.trustRadius.push_back(it.trustRadius);
    }
  a.history = h;
  ArchiveControlPoints cp;
  cp.radii = chosen.controls.radii;
  cp.restDisplacement = chosen.controls.displacement;
  for (const ControlPoint& c : space.controlPoints()) {
    cp.rod.push_back(c.rod);
    cp.arcFraction.push_back(c.arcFraction);
    cp.vertex.push_back(c.vertex);
  }
  // The bound activity is the final design's; a fallback design has none.
  if (!chosen.fallback && r.boundActivity.computed) {
    const RadiusBoundActivity& b = r.boundActivity;
    cp.radiusBounds = ArchiveControlPoints::RadiusBounds{b.lowerBound,      b.upperBound,     b.atLower,
                                                         b.atUpper,         b.lowerElasticity, b.upperElasticity};
  }
  a.controlPoints = cp;
  ArchiveOptimizeSummary s;
  s.method = method;
  s.iterations = r.iterations;
  s.timeSeconds = r.timeSeconds;
  s.message = r.message;
  s.evaluationSeconds = r.evaluationSeconds;
  s.solverSeconds = r.solverSeconds;
  s.peakMemoryBytes = r.peakMemoryBytes;
  s.evaluations = r.evaluations;
  if (!chosen.note.empty()) s.message += "; " + chosen.note;
  a.optimize = s;
  a.extraRootAttributes["archived_design"] = chosen.fallback ? chosen.label : "final";
  if (chosen.gapTolerance > 0) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", chosen.gapTolerance);
    a.extraRootAttributes["equilibrium_gap_tolerance"] = buf;
  }
  if (chosen.outOfPlane)
    a.extraRootAttributes["effects_note"] =
        "the scene was inferred planar and optimized in plane, but an in-plane equilibrium of the archived design "
        "was unstable out of plane; its poses were solved again in 3D with twist";
  const bool converged =
      r.converged() && chosen.allConverged && !chosen.fallback && !chosen.offPath && !chosen.outOfPlane;
  a.status = converged ? "converged" : (r.outcome == Outcome::NumericalFailure ? "failed" : "not_converged");
  return a;
}

Scene spatialScene(const Scene& scene, const EffectSet& inferred) {
  std::vector<Effect> fx;
  for (int e = 0; e < kEffectCount; ++e)
    if (inferred.on[e] || static_cast<Effect>(e) == Effect::Twist) fx.push_back(static_cast<Effect>(e));
  Scene out = scene;
  out.effects = fx;
  return out;
}

}  // namespace rodmesh::cli
