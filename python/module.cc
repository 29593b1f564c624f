// rodmesh._rodmesh: the C++ side of the Python package (python/rodmesh/).
//
// Thin: scenes go through the scene reader and writer, runs through
// apps/run.hh (the code the CLI runs), archives through io/archive. The
// Python layer (python/rodmesh/__init__.py) turns what this returns into
// Scene / Result objects.
//
// Threads and signals: a run executes on a worker thread while the calling
// thread waits without the GIL and, every 50 ms, takes it to run Python's
// signal handlers (PyErr_CheckSignals). A KeyboardInterrupt (Ctrl-C) then
// sets the run's stop flag, as SIGINT does for the CLI: the optimizer stops
// and the best design is kept. The progress callback runs on the worker
// thread with the GIL held.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "apps/cli_common.hh"
#include "apps/flag_checks.hh"
#include "apps/run.hh"
#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "io/scene_writer.hh"
#include "model/design.hh"
#include "model/design_space.hh"
#include "model/pose_system.hh"
#include "solver/equilibrium.hh"

#include <atomic>
#include <chrono>
#include <exception>
#include <future>
#include <memory>
#include <set>
#include <string>
#include <thread>

#ifdef RODMESH_HAVE_NLP
#include "nlp/sand.hh"
#endif

namespace py = pybind11;
using namespace rodmesh;

namespace {

using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A scene and the text it was parsed from (the archive stores the text).
struct PyScene {
  Scene scene;
};

PyScene parseSceneText(const std::string& text, const std::string& name) {
  PyScene s;
  s.scene = parseScene(text, name);
  return s;
}

// Runs `work` on a worker thread; see the file comment. `stop` is set when
// Python raises KeyboardInterrupt while waiting (or another exception from a
// signal handler, which is then re-raised after the run).
template <class R>
R runInterruptible(const std::function<R()>& work, std::atomic<bool>& stop, bool& interrupted) {
  std::packaged_task<R()> task(work);
  std::future<R> result = task.get_future();
  std::exception_ptr pending;  // a non-KeyboardInterrupt exception from a signal handler
  {
    py::gil_scoped_release release;
    std::thread worker(std::move(task));
    while (result.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
      py::gil_scoped_acquire acquire;
      if (PyErr_CheckSignals() != 0) {
        stop = true;
        if (PyErr_ExceptionMatches(PyExc_KeyboardInterrupt)) {
          interrupted = true;
          PyErr_Clear();
        } else {
          py::error_already_set e;
          if (!pending) pending = std::make_exception_ptr(e);
        }
      }
    }
    worker.join();
  }
  R r = result.get();  // rethrows the run's own exception
  if (pending) std::rethrow_exception(pending);
  return r;
}

// ---- keyword options, named like the CLI flags (max_iter for --max-iter)

std::string flagOf(const std::string& key) {
  std::string f = "--" + key;
  for (char& c : f)
    if (c == '_') c = '-';
  return f;
}

void rejectUnknown(const py::dict& kw, const std::set<std::string>& known, const char* fn) {
  for (auto item : kw) {
    const std::string k = py::str(item.first);
    if (!known.count(k)) {
      std::string list;
      for (const std::string& n : known) list += (list.empty() ? "" : ", ") + n;
      throw py::type_error(std::string(fn) + "() got an unexpected keyword argument '" + k + "' (options: " + list +
                           ")");
    }
  }
}

// The CLI's own range checks on a keyword option's text (str() of the
// value), with the CLI's message: "--tol: must be a number in ...".
void checkReal(const py::dict& kw, const char* key, const cli::RealRange& range) {
  if (!kw.contains(key) || kw[key].is_none()) return;
  const std::string problem = cli::realNumberProblem(py::str(kw[key]).cast<std::string>(), range);
  if (!problem.empty()) throw InputError(flagOf(key) + ": " + problem);
}
void checkWhole(const py::dict& kw, const char* key, long long lo, long long hi) {
  if (!kw.contains(key) || kw[key].is_none()) return;
  const std::string problem = cli::wholeNumberProblem(py::str(kw[key]).cast<std::string>(), lo, hi);
  if (!problem.empty()) throw InputError(flagOf(key) + ": " + problem);
}

cli::SimulateOptions simulateOptions(const py::dict& kw) {
  rejectUnknown(kw, {"tol", "max_iter", "static_solver", "time_limit", "dynamic", "duration", "fps", "max_step",
                     "ramp"},
                "simulate");
  checkReal(kw, "tol", cli::kSimulateTolRange);
  checkWhole(kw, "max_iter", 1, cli::kMaxSimulateIterations);
  checkReal(kw, "time_limit", cli::kPositiveSecondsRange);
  checkReal(kw, "duration", cli::kDurationRange);
  checkReal(kw, "fps", cli::kFpsRange);
  checkReal(kw, "max_step", cli::kPositiveSecondsRange);
  checkReal(kw, "ramp", cli::kSecondsRange);
  cli::SimulateOptions o;
  auto has = [&](const char* k) { return kw.contains(k) && !kw[k].is_none(); };
  if (has("tol")) o.newton.tolerance = kw["tol"].cast<double>();
  if (has("max_iter")) o.newton.maxIterations = kw["max_iter"].cast<int>();
  if (has("static_solver")) {
    o.staticSolver = kw["static_solver"].cast<std::string>();
    if (o.staticSolver != "newton" && o.staticSolver != "relaxation")
      throw InputError("--static-solver: " + o.staticSolver + " not in {newton,relaxation}");
  }
  if (has("time_limit")) o.timeLimit = kw["time_limit"].cast<double>();
  if (has("dynamic")) o.dynamic = kw["dynamic"].cast<bool>();
  if (has("duration")) o.duration = kw["duration"].cast<double>();
  if (has("fps")) o.fps = kw["fps"].cast<double>();
  if (has("max_step")) o.dynamics.maxStep = kw["max_step"].cast<double>();
  if (has("ramp")) o.ramp = kw["ramp"].cast<double>();
  std::set<std::string> given;
  for (auto item : kw)
    if (!item.second.is_none()) given.insert(flagOf(py::str(item.first)));
  // --dynamic is a flag: dynamic=False is "not given".
  if (!o.dynamic) given.erase("--dynamic");
  cli::resolveSimulateOptions(o, [&](const char* flag) { return given.count(flag) > 0; });
  return o;
}

cli::OptimizeOptions optimizeOptions(const py::dict& kw) {
  rejectUnknown(kw,
                {"method", "max_iter", "time_limit", "tol", "schedule", "threads", "design_derivatives", "ipopt",
                 "no_imperfection_back_off", "scene_start"},
                "optimize");
  checkWhole(kw, "max_iter", 0, cli::kMaxOptimizeIterations);
  checkReal(kw, "time_limit", cli::kTimeLimitRange);
  checkReal(kw, "tol", cli::kOptimizeTolRange);
  checkWhole(kw, "threads", 1, cli::kMaxThreads);
  cli::OptimizeOptions o;
  auto has = [&](const char* k) { return kw.contains(k) && !kw[k].is_none(); };
  auto member = [&](const char* k, std::initializer_list<const char*> allowed) {
    const std::string v = kw[k].cast<std::string>();
    std::string list;
    for (const char* a : allowed) {
      if (v == a) return v;
      list += (list.empty() ? "" : ",") + std::string(a);
    }
    throw InputError(flagOf(k) + ": " + v + " not in {" + list + "}");
  };
  if (has("method")) o.method = member("method", {"sand", "reduced", "newton"});
  if (has("max_iter")) o.optimizer.maxIterations = kw["max_iter"].cast<int>();
  if (has("time_limit")) o.optimizer.timeLimit = kw["time_limit"].cast<double>();
  if (has("tol")) o.optimizer.tolerance = kw["tol"].cast<double>();
  if (has("schedule")) o.schedule = member("schedule", {"paper", "joint", "levels", "multilevel"});
  if (has("threads")) o.optimizer.threads = kw["threads"].cast<int>();
  if (has("design_derivatives")) o.designDerivatives = member("design_derivatives", {"exact", "fd", "fd-resolve"});
  if (has("no_imperfection_back_off")) o.noImperfectionBackOff = kw["no_imperfection_back_off"].cast<bool>();
  if (has("scene_start")) o.sceneStart = kw["scene_start"].cast<bool>();
  if (has("ipopt")) {
    py::object ip = kw["ipopt"];
    if (py::isinstance<py::dict>(ip)) {
      for (auto item : ip.cast<py::dict>())
        o.ipopt.push_back(py::str(item.first).cast<std::string>() + "=" + py::str(item.second).cast<std::string>());
    } else {
      o.ipopt = ip.cast<std::vector<std::string>>();
    }
  }
  cli::checkOptimizeOptions(o);
  return o;
}

py::dict iterateDict(const DesignIterate& it) {
  py::dict d;
  d["iteration"] = it.iteration;
  d["level"] = it.level;
  d["phase"] = it.phase;
  d["objective"] = it.objective;
  d["rms_error"] = it.rms;
  d["gradient_norm"] = it.gradientNorm;
  d["step"] = it.step;
  d["time_s"] = it.elapsed;
  d["evaluations"] = it.evaluations;
  d["constraint_violation"] = it.constraintViolation;
  d["dual_infeasibility"] = it.dualInfeasibility;
  d["best_rms_error"] = it.confirmedRms;
  d["best_iteration"] = it.confirmedIteration;
  d["cg_iterations"] = it.cgIterations;
  d["trust_radius"] = it.trustRadius;
  return d;
}

Archive simulate(const PyScene& s, const py::dict& kw, bool quiet) {
  cli::SimulateOptions o = simulateOptions(kw);
  std::atomic<bool> stop{false};
  bool interrupted = false;
  o.newton.cancel = &stop;
  const Scene& scene = s.scene;
  std::function<Archive()> work = [&]() { return cli::runSimulate(scene, o, quiet); };
  return runInterruptible(work, stop, interrupted);
}

Archive optimize(const PyScene& s, const py::dict& kw, const py::object& callback, bool quiet) {
  cli::OptimizeOptions o = optimizeOptions(kw);
  const Scene& scene = s.scene;
  validateForOptimize(scene);
  std::unique_ptr<SceneModel> model;
  std::unique_ptr<DesignSpace> space;
  try {
    model = std::make_unique<SceneModel>(scene);
    space = std::make_unique<DesignSpace>(scene, model->effects());
  } catch (const std::invalid_argument& e) {
    throw InputError(scene.sourcePath + ": " + e.what());
  }
  std::atomic<bool> stop{false};
  bool interrupted = false;
  o.optimizer.stopRequested = [&stop] { return stop.load(); };
  std::exception_ptr callbackError;
  DesignProgress progress;
  if (!callback.is_none()) {
    progress = [&](const DesignIterate& it) {
      if (stop) return;
      py::gil_scoped_acquire acquire;
      try {
        py::object r = callback(iterateDict(it));
        if (r.ptr() == Py_False) stop = true;
      } catch (py::error_already_set& e) {
        stop = true;
        if (!callbackError) callbackError = std::current_exception();
      }
    };
  }
  std::function<Archive()> work = [&]() {
    cli::OptimizeRun run = cli::runOptimize(scene, *model, *space, o, progress, quiet);
    return std::move(run.archive);
  };
  Archive a = runInterruptible(work, stop, interrupted);
  if (callbackError) {
    py::gil_scoped_acquire acquire;
    std::rethrow_exception(callbackError);
  }
  return a;
}

// ---- archives as Python dicts of numpy arrays


template <class T>
py::array_t<T> vec(const std::vector<T>& v) {
  return py::array_t<T>(static_cast<py::ssize_t>(v.size()), v.data());
}

py::dict archiveDict(const Archive& a) {
  py::dict d;
  d["format"] = a.format;
  d["version"] = a.version;
  d["command"] = a.command;
  d["status"] = a.status;
  d["scene_json"] = a.sceneJson;
  py::dict model;
  model["effects"] = a.effects;
  model["dofs_per_pose"] = a.dofsPerPose;
  model["n_vertices"] = a.nVertices;
  model["n_edges"] = a.nEdges;
  model["n_rods"] = a.nRods;
  model["n_connections"] = a.nConnections;
  model["planar"] = a.planar != 0;
  d["model"] = model;
  d["rest_positions"] = py::cast(RowMat(a.restPositions));
  d["radii"] = py::cast(RowMat(a.radii));
  d["initial_radii"] = a.initialRadii ? py::object(py::cast(RowMat(*a.initialRadii))) : py::none();
  if (a.controlPoints) {
    const ArchiveControlPoints& c = *a.controlPoints;
    py::dict cp;
    cp["radii"] = c.radii.rows() ? py::object(py::cast(RowMat(c.radii))) : py::none();
    cp["rest_displacement"] = c.restDisplacement.rows() ? py::object(py::cast(RowMat(c.restDisplacement))) : py::none();
    cp["rod"] = vec(c.rod);
    cp["arc_fraction"] = vec(c.arcFraction);
    cp["vertex"] = vec(c.vertex);
    if (c.radiusBounds) {
      const ArchiveControlPoints::RadiusBounds& b = *c.radiusBounds;
      py::dict rb;
      rb["min"] = b.min;
      rb["max"] = b.max;
      rb["at_min"] = b.atMin;
      rb["at_max"] = b.atMax;
      rb["elasticity_min"] = b.minElasticity;
      rb["elasticity_max"] = b.maxElasticity;
      cp["radius_bounds"] = rb;
    } else {
      cp["radius_bounds"] = py::none();
    }
    d["control_points"] = cp;
  } else {
    d["control_points"] = py::none();
  }
  py::list poses;
  for (const ArchivePose& p : a.poses) {
    py::dict q;
    q["name"] = p.name;
    q["positions"] = py::cast(RowMat(p.positions));
    q["twist"] = p.twist.size() ? py::object(py::cast(Eigen::VectorXd(p.twist))) : py::none();
    q["target"] = p.target.rows() ? py::object(py::cast(RowMat(p.target))) : py::none();
    q["residual_norm"] = p.residualNorm;
    q["rms_error"] = p.rmsError ? py::object(py::float_(*p.rmsError)) : py::none();
    q["status"] = p.status;
    q["iterations"] = p.iterations;
    q["time_s"] = p.timeSeconds;
    q["initial_positions"] =
        p.initialPositions.rows() ? py::object(py::cast(RowMat(p.initialPositions))) : py::none();
    q["equilibrium_gap"] = p.equilibriumGap ? py::object(py::float_(*p.equilibriumGap)) : py::none();
    q["stable"] = p.stable >= 0 ? py::object(py::bool_(p.stable == 1)) : py::none();
    q["out_of_plane_stable"] = p.outOfPlaneStable >= 0 ? py::object(py::bool_(p.outOfPlaneStable == 1)) : py::none();
    q["smallest_eigenvalue"] = p.smallestEigenvalue ? py::object(py::float_(*p.smallestEigenvalue)) : py::none();
    q["unloaded_smallest_eigenvalue"] =
        p.unloadedSmallestEigenvalue ? py::object(py::float_(*p.unloadedSmallestEigenvalue)) : py::none();
    q["critical_points"] = py::cast(RowMat(p.criticalPoints));
    q["imperfection_sensitive"] =
        p.imperfectionSensitive >= 0 ? py::object(py::bool_(p.imperfectionSensitive == 1)) : py::none();
    q["imperfection_gap"] = p.imperfectionGap ? py::object(py::float_(*p.imperfectionGap)) : py::none();
    poses.append(q);
  }
  d["poses"] = poses;
  py::list frames;
  for (const ArchiveFrames& f : a.frames) {
    py::dict q;
    q["name"] = f.name;
    q["time"] = py::cast(Eigen::VectorXd(f.time));
    const py::ssize_t T = static_cast<py::ssize_t>(f.positions.size());
    const py::ssize_t V = T ? f.positions[0].rows() : 0;
    py::array_t<double> x({T, V, py::ssize_t(3)});
    auto w = x.mutable_unchecked<3>();
    for (py::ssize_t t = 0; t < T; ++t)
      for (py::ssize_t v = 0; v < V; ++v)
        for (int k = 0; k < 3; ++k) w(t, v, k) = f.positions[t](v, k);
    q["positions"] = x;
    frames.append(q);
  }
  d["frames"] = frames;
  if (a.history) {
    const ArchiveHistory& h = *a.history;
    py::dict q;
    q["iteration"] = vec(h.iteration);
    q["time_s"] = vec(h.timeSeconds);
    q["objective"] = vec(h.objective);
    q["rms_error"] = vec(h.rmsError);
    if (!h.level.empty()) q["level"] = vec(h.level);
    if (!h.constraintViolation.empty()) q["constraint_violation"] = vec(h.constraintViolation);
    if (!h.gradientNorm.empty()) q["gradient_norm"] = vec(h.gradientNorm);
    if (!h.phase.empty()) q["phase"] = py::cast(h.phase);
    if (!h.confirmedRms.empty()) q["best_rms_error"] = vec(h.confirmedRms);
    d["history"] = q;
  } else {
    d["history"] = py::none();
  }
  std::string message;
  if (a.optimize) {
    const ArchiveOptimizeSummary& s = *a.optimize;
    py::dict q;
    q["method"] = s.method;
    q["iterations"] = s.iterations;
    q["time_s"] = s.timeSeconds;
    q["message"] = s.message;
    q["evaluation_s"] = s.evaluationSeconds;
    q["solver_s"] = s.solverSeconds;
    q["peak_memory_bytes"] = s.peakMemoryBytes;
    d["optimize"] = q;
    message = s.message;
  } else {
    d["optimize"] = py::none();
  }
  py::dict extra;
  for (const auto& [k, v] : a.extraRootAttributes) extra[py::str(k)] = v;
  d["attributes"] = extra;
  if (message.empty()) {
    auto it = a.extraRootAttributes.find("message");
    if (it != a.extraRootAttributes.end()) message = it->second;
  }
  d["message"] = message;
  return d;
}

// ---- one pose's energy and derivatives at explicit states

// Every call evaluates the (immutable) pose model at the state it is given:
// charts at the scene design's rest frames and the load factor passed, so that
// nothing depends on earlier calls.
class PyPoseModel {
 public:
  PyPoseModel(const PyScene& s, int pose) : scene_(std::make_unique<Scene>(s.scene)) {
    try {
      model_ = std::make_unique<SceneModel>(*scene_);
    } catch (const std::invalid_argument& e) {
      throw InputError(scene_->sourcePath + ": rods: " + e.what());
    }
    if (pose < 0 || pose >= model_->numPoses())
      throw py::index_error("pose " + std::to_string(pose) + " out of range [0, " +
                            std::to_string(model_->numPoses()) + ")");
    pose_ = pose;
    design_ = Design::fromScene(*scene_);
  }

  int pose() const { return pose_; }
  std::string poseName() const { return scene_->poses[pose_].name; }
  int numDofs() const { return sys().numDofs(); }
  int numParameters() const { return design_.numParameters(); }
  Eigen::VectorXd designVector() const { return design_.toVector(); }

  // The rest configuration of design p in this model's coordinates: twists
  // are measured from the scene design's rest frames, so a design with
  // another rest shape has non-zero twist unknowns at its rest state.
  Eigen::VectorXd restState(const std::optional<Eigen::VectorXd>& p) const {
    const Design d = design(p);
    Eigen::VectorXd u = sys().restDofs(d);
    if (sys().hasTwist() && p) {
      const Eigen::VectorXd offset = sys().materialTwists(at(u, 0.0), d);
      for (int e = 0; e < offset.size(); ++e) u[sys().thetaDof(e)] -= offset[e];
    }
    return u;
  }

  double energy(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p, double loadFactor,
                const std::optional<Eigen::VectorXd>& internal) const {
    return sys().energy(checked(u, loadFactor, internal), design(p));
  }
  Eigen::VectorXd gradient(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p, double loadFactor,
                           const std::optional<Eigen::VectorXd>& internal) const {
    Eigen::VectorXd g;
    sys().evaluate(checked(u, loadFactor, internal), design(p), &g, nullptr);
    return g;
  }
  Eigen::SparseMatrix<double> hessian(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p,
                                      double loadFactor, const std::optional<Eigen::VectorXd>& internal) const {
    return sys().joint(checked(u, loadFactor, internal), design(p)).Huu;
  }
  // Internal variables of the term blocks (a plastic tie's rest length):
  // their initial values, and the values after the blocks' update rules at
  // u (the given ones, or the initial ones, when nothing changes).
  Eigen::VectorXd initialInternal() const { return sys().initialInternal(); }
  Eigen::VectorXd advancedInternal(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& internal,
                                   const std::optional<Eigen::VectorXd>& p, double loadFactor) const {
    const PoseState s = checked(u, loadFactor, internal);
    if (std::optional<PoseState> next = sys().advancedInternal(s, design(p))) return next->internal;
    return s.internal.size() ? s.internal : sys().initialInternal();
  }
  Eigen::SparseMatrix<double> designJacobian(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p,
                                             double loadFactor) const {
    return sys().joint(checked(u, loadFactor), design(p)).Hup;
  }
  Eigen::VectorXd energyDesignGradient(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p,
                                       double loadFactor) const {
    return sys().joint(checked(u, loadFactor), design(p)).gp;
  }
  RowMat positions(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p, double loadFactor) const {
    const std::vector<Vec3> x = sys().positions(checked(u, loadFactor), design(p));
    RowMat m(x.size(), 3);
    for (std::size_t i = 0; i < x.size(); ++i) m.row(i) = x[i].transpose();
    return m;
  }
  Eigen::VectorXd materialTwists(const Eigen::VectorXd& u, const std::optional<Eigen::VectorXd>& p,
                                 double loadFactor) const {
    return sys().materialTwists(checked(u, loadFactor), design(p));
  }

  py::dict dofInfo() const {
    const PoseSystem& s = sys();
    const int n = s.numDofs();
    std::vector<std::string> kind(n);
    std::vector<int> vertex(n, -1), coord(n, -1), edge(n, -1);
    const std::vector<int>& first = s.vertexDof();
    for (std::size_t v = 0; v < first.size(); ++v) {
      if (first[v] < 0) continue;
      for (int k = 0; k < s.dofsPerVertex(); ++k) {
        kind[first[v] + k] = "position";
        vertex[first[v] + k] = static_cast<int>(v);
        coord[first[v] + k] = k;
      }
    }
    if (s.hasTwist())
      for (int e = 0; e < model_->network().numEdges(); ++e) {
        kind[s.thetaDof(e)] = "twist";
        edge[s.thetaDof(e)] = e;
      }
    const EffectSet& fx = model_->effects();
    py::dict d;
    d["kind"] = kind;
    d["vertex"] = vec(vertex);
    d["coordinate"] = vec(coord);
    d["edge"] = vec(edge);
    d["planar"] = fx.planar;
    if (fx.planar) {
      d["plane_origin"] = Eigen::Vector3d(fx.planeOrigin);
      d["plane_basis"] = RowMat(fx.planeBasis);
    }
    std::vector<int> held;
    for (int v = 0; v < static_cast<int>(first.size()); ++v)
      if (s.isHeld(v)) held.push_back(v);
    d["held_vertices"] = vec(held);
    return d;
  }

 private:
  const PoseSystem& sys() const { return model_->pose(pose_); }
  Design design(const std::optional<Eigen::VectorXd>& p) const {
    if (!p) return design_;
    if (p->size() != design_.numParameters())
      throw py::value_error("p has " + std::to_string(p->size()) + " entries, expected " +
                            std::to_string(design_.numParameters()) + " (3 rest coordinates and 2 radii per vertex)");
    Design d = design_;
    d.fromVector(*p);
    return d;
  }
  // The state of u at a load factor, its charts at the rest frames of the
  // scene's design whatever p is: the twist unknowns are then coordinates
  // independent of p, and design derivatives are derivatives at fixed u.
  PoseState at(const Eigen::VectorXd& u, double loadFactor) const {
    return sys().withRestCharts(u, design_, loadFactor);
  }
  PoseState checked(const Eigen::VectorXd& u, double loadFactor,
                    const std::optional<Eigen::VectorXd>& internal = std::nullopt) const {
    if (u.size() != numDofs())
      throw py::value_error("u has " + std::to_string(u.size()) + " entries, expected " + std::to_string(numDofs()));
    PoseState s = at(u, loadFactor);
    if (internal) {
      if (internal->size() != sys().numInternal())
        throw py::value_error("internal has " + std::to_string(internal->size()) + " entries, expected " +
                              std::to_string(sys().numInternal()) + " (see initial_internal)");
      s.internal = *internal;
    }
    return s;
  }

  std::unique_ptr<Scene> scene_;  // SceneModel keeps a reference
  std::unique_ptr<SceneModel> model_;
  int pose_ = 0;
  Design design_;
};

}  // namespace

#ifdef RODMESH_HAVE_MESHING
void bindMeshing(py::module_& m, const std::function<py::object(Scene&&)>& wrap);  // python/meshing.cc
#endif

PYBIND11_MODULE(_rodmesh, m) {
  m.doc() = "rodmesh C++ core (use the rodmesh package)";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, printableText(e.what()).c_str());
    }
  });
  m.attr("version") = cli::versionString();
  m.attr("python_executable") = RODMESH_PYTHON_EXECUTABLE;
#ifdef RODMESH_HAVE_NLP
  m.attr("have_sand") = true;
#else
  m.attr("have_sand") = false;
#endif

  py::class_<PyScene>(m, "_Scene")
      .def_static("load",
                  [](const std::string& path) {
                    PyScene s;
                    s.scene = readSceneFile(path);
                    return s;
                  })
      .def_static("parse", &parseSceneText, py::arg("text"), py::arg("name"))
      .def("to_json", [](const PyScene& s) { return sceneToJson(s.scene); })
      .def("save", [](const PyScene& s, const std::string& path) { writeSceneFile(s.scene, path); })
      .def_property_readonly("source_path", [](const PyScene& s) { return s.scene.sourcePath; })
      .def_property_readonly("source_text", [](const PyScene& s) { return s.scene.sourceText; })
      .def_property_readonly("pose_names",
                             [](const PyScene& s) {
                               std::vector<std::string> n;
                               for (const Pose& p : s.scene.poses) n.push_back(p.name);
                               return n;
                             })
      .def_property_readonly("n_vertices", [](const PyScene& s) { return s.scene.vertices.size(); })
      .def("validate_for_optimize", [](const PyScene& s) { validateForOptimize(s.scene); });
  m.def("last_scene_warnings", [] { return lastSceneWarnings(); });

  py::class_<Archive>(m, "_Archive")
      .def("save", [](const Archive& a, const std::string& path) { writeArchive(a, path); })
      .def("to_dict", &archiveDict);
  m.def("load_archive", [](const std::string& path) { return loadArchive(path).archive; });

  m.def("simulate", &simulate, py::arg("scene"), py::arg("options"), py::arg("quiet") = true);
  m.def("optimize", &optimize, py::arg("scene"), py::arg("options"), py::arg("callback") = py::none(),
        py::arg("quiet") = true);
  m.def("keep_large_blocks_on_heap", &rodmesh::cli::keepLargeBlocksOnHeap);

  py::class_<PyPoseModel>(m, "_PoseModel")
      .def(py::init<const PyScene&, int>())
      .def_property_readonly("pose", &PyPoseModel::pose)
      .def_property_readonly("pose_name", &PyPoseModel::poseName)
      .def_property_readonly("n_dofs", &PyPoseModel::numDofs)
      .def_property_readonly("n_parameters", &PyPoseModel::numParameters)
      .def("design_vector", &PyPoseModel::designVector)
      .def("dof_info", &PyPoseModel::dofInfo)
      .def("rest_state", &PyPoseModel::restState, py::arg("p") = py::none())
      .def("energy", &PyPoseModel::energy, py::arg("u"), py::arg("p") = py::none(), py::arg("load_factor") = 1.0,
           py::arg("internal") = py::none())
      .def("gradient", &PyPoseModel::gradient, py::arg("u"), py::arg("p") = py::none(), py::arg("load_factor") = 1.0,
           py::arg("internal") = py::none())
      .def("hessian", &PyPoseModel::hessian, py::arg("u"), py::arg("p") = py::none(), py::arg("load_factor") = 1.0,
           py::arg("internal") = py::none())
      .def_property_readonly("initial_internal", &PyPoseModel::initialInternal)
      .def("advanced_internal", &PyPoseModel::advancedInternal, py::arg("u"), py::arg("internal") = py::none(),
           py::arg("p") = py::none(), py::arg("load_factor") = 1.0)
      .def("design_jacobian", &PyPoseModel::designJacobian, py::arg("u"), py::arg("p") = py::none(),
           py::arg("load_factor") = 1.0)
      .def("energy_design_gradient", &PyPoseModel::energyDesignGradient, py::arg("u"), py::arg("p") = py::none(),
           py::arg("load_factor") = 1.0)
      .def("positions", &PyPoseModel::positions, py::arg("u"), py::arg("p") = py::none(),
           py::arg("load_factor") = 1.0)
      .def("material_twists", &PyPoseModel::materialTwists, py::arg("u"), py::arg("p") = py::none(),
           py::arg("load_factor") = 1.0);

#ifdef RODMESH_HAVE_MESHING
  bindMeshing(m, [](Scene&& s) {
    PyScene p;
    p.scene = std::move(s);
    return py::cast(std::move(p));
  });
  m.attr("have_meshing") = true;
#else
  m.attr("have_meshing") = false;
#endif
}
