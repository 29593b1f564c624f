#include "io/archive.hh"

#include "io/interrupt.hh"

#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <thread>

namespace rodmesh {
namespace {

// Small RAII holder for HDF5 identifiers.
struct Hid {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Hid(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() { if (id >= 0 && close) close(id); }
  operator hid_t() const { return id; }
};

void check(herr_t status, const std::string& what) {
  if (status < 0) throw std::runtime_error("HDF5 error while writing " + what);
}
hid_t checkId(hid_t id, const std::string& what) {
  if (id < 0) throw std::runtime_error("HDF5 error while writing " + what);
  return id;
}

hid_t stringType() {
  hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, H5T_VARIABLE);
  H5Tset_cset(t, H5T_CSET_UTF8);
  return t;
}

void writeStringAttr(hid_t obj, const char* name, const std::string& value) {
  Hid type(stringType(), H5Tclose);
  Hid space(H5Screate(H5S_SCALAR), H5Sclose);
  Hid attr(checkId(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), name), H5Aclose);
  const char* p = value.c_str();
  check(H5Awrite(attr, type, &p), name);
}

template <class T>
void writeScalarAttr(hid_t obj, const char* name, T value, hid_t memType) {
  Hid space(H5Screate(H5S_SCALAR), H5Sclose);
  Hid attr(checkId(H5Acreate2(obj, name, memType, space, H5P_DEFAULT, H5P_DEFAULT), name), H5Aclose);
  check(H5Awrite(attr, memType, &value), name);
}

void writeDoubles(hid_t loc, const char* name, const double* data, const std::vector<hsize_t>& dims) {
  Hid space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose);
  Hid ds(checkId(H5Dcreate2(loc, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), name), H5Dclose);
  std::size_t n = 1;
  for (auto d : dims) n *= d;
  if (n > 0) check(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), name);
}

// 1-D integer dataset stored as `fileType` (H5T_STD_I64LE, H5T_STD_I32LE).
template <class T>
void writeInts(hid_t loc, const char* name, const std::vector<T>& values, hid_t fileType, hid_t memType) {
  const hsize_t n = values.size();
  Hid space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Hid ds(checkId(H5Dcreate2(loc, name, fileType, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), name), H5Dclose);
  if (n > 0) check(H5Dwrite(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), name);
}

// 1-D dataset of variable-length UTF-8 strings.
void writeStrings(hid_t loc, const char* name, const std::vector<std::string>& values) {
  Hid type(stringType(), H5Tclose);
  const hsize_t n = values.size();
  Hid space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Hid ds(checkId(H5Dcreate2(loc, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), name), H5Dclose);
  std::vector<const char*> ptrs;
  for (const std::string& v : values) ptrs.push_back(v.c_str());
  if (n > 0) check(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()), name);
}

void writeStringDataset(hid_t loc, const char* name, const std::string& value) {
  Hid type(stringType(), H5Tclose);
  Hid space(H5Screate(H5S_SCALAR), H5Sclose);
  Hid ds(checkId(H5Dcreate2(loc, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), name), H5Dclose);
  const char* p = value.c_str();
  check(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, &p), name);
}

hid_t makeGroup(hid_t loc, const char* name) {
  return checkId(H5Gcreate2(loc, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), name);
}

// ---- reading ----

bool exists(hid_t loc, const std::string& path) {
  // Check each component so that intermediate groups may be missing.
  std::size_t pos = 0;
  while (true) {
    pos = path.find('/', pos + 1);
    std::string part = path.substr(0, pos);
    if (!part.empty() && H5Lexists(loc, part.c_str(), H5P_DEFAULT) <= 0) return false;
    if (pos == std::string::npos) return true;
  }
}

std::string readStringAttr(hid_t obj, const char* name, const std::string& file) {
  if (H5Aexists(obj, name) <= 0) return "";
  Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Hid ftype(H5Aget_type(attr), H5Tclose);
  if (H5Tget_class(ftype) != H5T_STRING) throw std::runtime_error(file + ": attribute " + name + " is not a string");
  if (H5Tis_variable_str(ftype) > 0) {
    Hid type(stringType(), H5Tclose);
    char* p = nullptr;
    if (H5Aread(attr, type, &p) < 0) throw std::runtime_error(file + ": cannot read attribute " + name);
    std::string out = p ? p : "";
    Hid space(H5Aget_space(attr), H5Sclose);
    H5Dvlen_reclaim(type, space, H5P_DEFAULT, &p);
    return out;
  }
  // One byte more than stored: a null-padded string may fill its whole size,
  // and a null-terminated memory type of that size would drop its last byte.
  std::size_t n = H5Tget_size(ftype) + 1;
  std::string out(n, '\0');
  Hid type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, n);
  if (H5Aread(attr, type, out.data()) < 0) throw std::runtime_error(file + ": cannot read attribute " + name);
  while (!out.empty() && out.back() == '\0') out.pop_back();
  return out;
}

template <class T>
std::optional<T> readScalarAttr(hid_t obj, const char* name, hid_t memType) {
  if (H5Aexists(obj, name) <= 0) return std::nullopt;
  Hid attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  T v{};
  if (H5Aread(attr, memType, &v) < 0) return std::nullopt;
  return v;
}

std::vector<double> readDoubles(hid_t loc, const std::string& name, std::vector<hsize_t>& dims, const std::string& file) {
  Hid ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (ds < 0) throw std::runtime_error(file + ": cannot open dataset " + name);
  Hid space(H5Dget_space(ds), H5Sclose);
  int rank = H5Sget_simple_extent_ndims(space);
  dims.assign(rank, 0);
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  std::size_t n = 1;
  for (auto d : dims) n *= d;
  std::vector<double> out(n);
  if (n > 0 && H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw std::runtime_error(file + ": cannot read dataset " + name);
  return out;
}

template <int C>
Eigen::Matrix<double, Eigen::Dynamic, C, Eigen::RowMajor> readMatrix(hid_t loc, const std::string& name,
                                                                     const std::string& file) {
  std::vector<hsize_t> dims;
  std::vector<double> d = readDoubles(loc, name, dims, file);
  if (dims.size() != 2 || dims[1] != static_cast<hsize_t>(C))
    throw std::runtime_error(file + ": dataset " + name + " should be N x " + std::to_string(C));
  Eigen::Matrix<double, Eigen::Dynamic, C, Eigen::RowMajor> m(dims[0], C);
  std::copy(d.begin(), d.end(), m.data());
  return m;
}

std::string readStringDataset(hid_t loc, const char* name, const std::string& file) {
  Hid ds(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose);
  if (ds < 0) throw std::runtime_error(file + ": cannot open dataset " + name);
  Hid type(stringType(), H5Tclose);
  char* p = nullptr;
  if (H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, &p) < 0)
    throw std::runtime_error(file + ": cannot read dataset " + name);
  std::string out = p ? p : "";
  Hid space(H5Dget_space(ds), H5Sclose);
  H5Dvlen_reclaim(type, space, H5P_DEFAULT, &p);
  return out;
}

// A 1-D dataset read as integers (HDF5 converts from any stored numeric type).
template <class T>
std::vector<T> readInts(hid_t loc, const std::string& name, hid_t memType, const std::string& file) {
  Hid ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (ds < 0) throw std::runtime_error(file + ": cannot open dataset " + name);
  Hid space(H5Dget_space(ds), H5Sclose);
  if (H5Sget_simple_extent_ndims(space) != 1) throw std::runtime_error(file + ": dataset " + name + " should be 1-D");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space, &n, nullptr);
  std::vector<T> out(n);
  if (n > 0 && H5Dread(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw std::runtime_error(file + ": cannot read dataset " + name + " as integers");
  return out;
}

std::vector<double> readVector(hid_t loc, const std::string& name, const std::string& file) {
  std::vector<hsize_t> dims;
  std::vector<double> v = readDoubles(loc, name, dims, file);
  if (dims.size() != 1) throw std::runtime_error(file + ": dataset " + name + " should be 1-D");
  return v;
}

std::vector<std::string> readStrings(hid_t loc, const std::string& name, const std::string& file) {
  Hid ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (ds < 0) throw std::runtime_error(file + ": cannot open dataset " + name);
  Hid ftype(H5Dget_type(ds), H5Tclose);
  if (H5Tget_class(ftype) != H5T_STRING || H5Tis_variable_str(ftype) <= 0)
    throw std::runtime_error(file + ": dataset " + name + " should hold variable-length strings");
  Hid space(H5Dget_space(ds), H5Sclose);
  if (H5Sget_simple_extent_ndims(space) != 1) throw std::runtime_error(file + ": dataset " + name + " should be 1-D");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space, &n, nullptr);
  std::vector<std::string> out;
  if (n == 0) return out;
  Hid type(stringType(), H5Tclose);
  std::vector<char*> ptrs(n, nullptr);
  if (H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
    throw std::runtime_error(file + ": cannot read dataset " + name);
  for (char* p : ptrs) out.emplace_back(p ? p : "");
  H5Dvlen_reclaim(type, space, H5P_DEFAULT, ptrs.data());
  return out;
}

// Rejects archives whose parts disagree in size (a programming error in the
// command that filled it); called before anything is written.
void checkConsistent(const Archive& a) {
  auto fail = [](const std::string& what) { throw std::runtime_error("inconsistent archive: " + what); };
  if (a.history) {
    const ArchiveHistory& h = *a.history;
    const std::size_t n = h.iteration.size();
    auto same = [&](std::size_t size, const char* name, bool optional) {
      if (size != n && !(optional && size == 0))
        fail(std::string("/history/") + name + " has " + std::to_string(size) + " entries, /history/iteration has " +
             std::to_string(n));
    };
    same(h.timeSeconds.size(), "time_s", false);
    same(h.objective.size(), "objective", false);
    same(h.rmsError.size(), "rms_error", false);
    same(h.level.size(), "level", true);
    same(h.constraintViolation.size(), "constraint_violation", true);
    same(h.gradientNorm.size(), "gradient_norm", true);
    same(h.phase.size(), "phase", true);
  }
  if (a.controlPoints) {
    const ArchiveControlPoints& c = *a.controlPoints;
    const std::size_t n = c.rod.size();
    auto same = [&](std::size_t size, const char* name, bool optional) {
      if (size != n && !(optional && size == 0))
        fail(std::string("/design/control_points/") + name + " has " + std::to_string(size) +
             " entries, /design/control_points/rod has " + std::to_string(n));
    };
    same(c.arcFraction.size(), "arc_fraction", false);
    same(c.vertex.size(), "vertex", true);
    same(static_cast<std::size_t>(c.radii.rows()), "radii", true);
    same(static_cast<std::size_t>(c.restDisplacement.rows()), "rest_displacement", true);
  }
  for (const ArchivePose& p : a.poses)
    if (p.initialPositions.rows() != 0 && p.initialPositions.rows() != p.positions.rows())
      fail("/poses/" + p.name + "/initial_positions has " + std::to_string(p.initialPositions.rows()) +
           " rows, positions has " + std::to_string(p.positions.rows()));
}

// Test hook (documented in archive.hh): seconds to wait before the rename.
void slowWriteHook() {
  const char* s = std::getenv("RODMESH_TEST_SLOW_WRITE");
  if (!s || !*s) return;
  const double seconds = std::strtod(s, nullptr);
  if (seconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(std::min(seconds, 600.0)));
}

herr_t collectName(hid_t, const char* name, const H5L_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

}  // namespace

void writeArchive(const Archive& a, const std::string& path) {
  checkConsistent(a);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  removeStaleTempFiles(path);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  // Until the end of this function SIGINT / SIGTERM unlink `tmp` and exit.
  TempFileGuard guard(tmp);
  try {
    {
      Hid file(checkId(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), tmp), H5Fclose);
      writeStringAttr(file, "format", a.format);
      writeStringAttr(file, "version", a.version);
      writeStringAttr(file, "command", a.command);
      writeStringAttr(file, "status", a.status);
      if (a.optimize) {
        const ArchiveOptimizeSummary& o = *a.optimize;
        writeStringAttr(file, "method", o.method);
        writeScalarAttr<long long>(file, "iterations", o.iterations, H5T_NATIVE_LLONG);
        writeScalarAttr<double>(file, "time_s", o.timeSeconds, H5T_NATIVE_DOUBLE);
        writeStringAttr(file, "message", o.message);
        writeScalarAttr<double>(file, "evaluation_time_s", o.evaluationSeconds, H5T_NATIVE_DOUBLE);
        writeScalarAttr<double>(file, "solver_time_s", o.solverSeconds, H5T_NATIVE_DOUBLE);
        writeScalarAttr<long long>(file, "peak_memory_bytes", o.peakMemoryBytes, H5T_NATIVE_LLONG);
      }
      for (const auto& [k, v] : a.extraRootAttributes) writeStringAttr(file, k.c_str(), v);
      writeStringDataset(file, "scene", a.sceneJson);

      {
        Hid model(makeGroup(file, "model"), H5Gclose);
        writeStringAttr(model, "effects", a.effects);
        writeStringAttr(model, "effects_reason", a.effectsReason);
        writeScalarAttr<long long>(model, "dofs_per_pose", a.dofsPerPose, H5T_NATIVE_LLONG);
        writeScalarAttr<long long>(model, "n_vertices", a.nVertices, H5T_NATIVE_LLONG);
        writeScalarAttr<long long>(model, "n_edges", a.nEdges, H5T_NATIVE_LLONG);
        writeScalarAttr<long long>(model, "n_rods", a.nRods, H5T_NATIVE_LLONG);
        writeScalarAttr<long long>(model, "n_connections", a.nConnections, H5T_NATIVE_LLONG);
        writeScalarAttr<int>(model, "planar", a.planar, H5T_NATIVE_INT);
      }
      {
        Hid rest(makeGroup(file, "rest"), H5Gclose);
        writeDoubles(rest, "positions", a.restPositions.data(), {(hsize_t)a.restPositions.rows(), 3});
      }
      {
        Hid design(makeGroup(file, "design"), H5Gclose);
        writeDoubles(design, "radii", a.radii.data(), {(hsize_t)a.radii.rows(), 2});
        if (a.initialRadii)
          writeDoubles(design, "initial_radii", a.initialRadii->data(), {(hsize_t)a.initialRadii->rows(), 2});
        if (a.controlPoints) {
          const ArchiveControlPoints& c = *a.controlPoints;
          Hid cp(makeGroup(design, "control_points"), H5Gclose);
          if (c.radii.rows() > 0) writeDoubles(cp, "radii", c.radii.data(), {(hsize_t)c.radii.rows(), 2});
          if (c.restDisplacement.rows() > 0)
            writeDoubles(cp, "rest_displacement", c.restDisplacement.data(), {(hsize_t)c.restDisplacement.rows(), 3});
          writeInts<int>(cp, "rod", c.rod, H5T_STD_I32LE, H5T_NATIVE_INT);
          writeDoubles(cp, "arc_fraction", c.arcFraction.data(), {(hsize_t)c.arcFraction.size()});
          if (!c.vertex.empty()) writeInts<int>(cp, "vertex", c.vertex, H5T_STD_I32LE, H5T_NATIVE_INT);
        }
      }
      {
        // Track creation order so that readers list poses in scene order.
        Hid gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
        H5Pset_link_creation_order(gcpl, H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
        Hid poses(checkId(H5Gcreate2(file, "poses", H5P_DEFAULT, gcpl, H5P_DEFAULT), "poses"), H5Gclose);
        for (const ArchivePose& p : a.poses) {
          Hid g(makeGroup(poses, p.name.c_str()), H5Gclose);
          writeDoubles(g, "positions", p.positions.data(), {(hsize_t)p.positions.rows(), 3});
          if (p.twist.size() > 0) writeDoubles(g, "twist", p.twist.data(), {(hsize_t)p.twist.size()});
          if (p.target.rows() > 0) writeDoubles(g, "target", p.target.data(), {(hsize_t)p.target.rows(), 3});
          writeScalarAttr<double>(g, "residual_norm", p.residualNorm, H5T_NATIVE_DOUBLE);
          if (p.rmsError) writeScalarAttr<double>(g, "rms_error", *p.rmsError, H5T_NATIVE_DOUBLE);
          if (!p.status.empty()) writeStringAttr(g, "status", p.status);
          writeScalarAttr<long long>(g, "iterations", p.iterations, H5T_NATIVE_LLONG);
          writeScalarAttr<double>(g, "time_s", p.timeSeconds, H5T_NATIVE_DOUBLE);
          if (p.outOfPlaneStable >= 0) writeScalarAttr<int>(g, "out_of_plane_stable", p.outOfPlaneStable, H5T_NATIVE_INT);
          if (p.initialPositions.rows() > 0)
            writeDoubles(g, "initial_positions", p.initialPositions.data(), {(hsize_t)p.initialPositions.rows(), 3});
          if (p.equilibriumGap) writeScalarAttr<double>(g, "equilibrium_gap", *p.equilibriumGap, H5T_NATIVE_DOUBLE);
        }
      }
      if (!a.frames.empty()) {
        Hid frames(makeGroup(file, "frames"), H5Gclose);
        for (const ArchiveFrames& f : a.frames) {
          Hid g(makeGroup(frames, f.name.c_str()), H5Gclose);
          const hsize_t T = f.positions.size();
          const hsize_t V = T ? f.positions[0].rows() : 0;
          std::vector<double> buf;
          buf.reserve(T * V * 3);
          for (const MatX3& m : f.positions) buf.insert(buf.end(), m.data(), m.data() + m.size());
          writeDoubles(g, "positions", buf.data(), {T, V, 3});
          writeDoubles(g, "time", f.time.data(), {(hsize_t)f.time.size()});
        }
      }
      if (a.history) {
        Hid h(makeGroup(file, "history"), H5Gclose);
        const ArchiveHistory& hs = *a.history;
        writeInts<long long>(h, "iteration", hs.iteration, H5T_STD_I64LE, H5T_NATIVE_LLONG);
        writeDoubles(h, "time_s", hs.timeSeconds.data(), {(hsize_t)hs.timeSeconds.size()});
        writeDoubles(h, "objective", hs.objective.data(), {(hsize_t)hs.objective.size()});
        writeDoubles(h, "rms_error", hs.rmsError.data(), {(hsize_t)hs.rmsError.size()});
        if (!hs.level.empty()) writeInts<long long>(h, "level", hs.level, H5T_STD_I64LE, H5T_NATIVE_LLONG);
        if (!hs.constraintViolation.empty())
          writeDoubles(h, "constraint_violation", hs.constraintViolation.data(),
                       {(hsize_t)hs.constraintViolation.size()});
        if (!hs.gradientNorm.empty())
          writeDoubles(h, "gradient_norm", hs.gradientNorm.data(), {(hsize_t)hs.gradientNorm.size()});
        if (!hs.phase.empty()) writeStrings(h, "phase", hs.phase);
      }
      check(H5Fflush(file, H5F_SCOPE_GLOBAL), tmp);
    }
    slowWriteHook();
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw std::runtime_error("cannot move " + tmp + " to " + path);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

Archive readArchive(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (access(path.c_str(), R_OK) != 0) throw std::runtime_error(path + ": cannot open archive");
  if (H5Fis_hdf5(path.c_str()) <= 0) throw std::runtime_error(path + ": not an HDF5 file");
  Hid file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (file < 0) throw std::runtime_error(path + ": cannot open archive");
  Archive a;
  a.format = readStringAttr(file, "format", path);
  if (a.format != "rodmesh-archive/1")
    throw std::runtime_error(path + ": not a rodmesh archive (format attribute is \"" + a.format + "\")");
  a.version = readStringAttr(file, "version", path);
  a.command = readStringAttr(file, "command", path);
  a.status = readStringAttr(file, "status", path);
  if (H5Aexists(file, "method") > 0) {
    ArchiveOptimizeSummary o;
    o.method = readStringAttr(file, "method", path);
    o.iterations = readScalarAttr<long long>(file, "iterations", H5T_NATIVE_LLONG).value_or(0);
    o.timeSeconds = readScalarAttr<double>(file, "time_s", H5T_NATIVE_DOUBLE).value_or(0.0);
    o.message = readStringAttr(file, "message", path);
    o.evaluationSeconds = readScalarAttr<double>(file, "evaluation_time_s", H5T_NATIVE_DOUBLE).value_or(0.0);
    o.solverSeconds = readScalarAttr<double>(file, "solver_time_s", H5T_NATIVE_DOUBLE).value_or(0.0);
    o.peakMemoryBytes = readScalarAttr<long long>(file, "peak_memory_bytes", H5T_NATIVE_LLONG).value_or(0);
    a.optimize = std::move(o);
  }
  if (exists(file, "scene")) a.sceneJson = readStringDataset(file, "scene", path);
  if (exists(file, "model")) {
    Hid model(H5Gopen2(file, "model", H5P_DEFAULT), H5Gclose);
    a.effects = readStringAttr(model, "effects", path);
    a.effectsReason = readStringAttr(model, "effects_reason", path);
    a.dofsPerPose = readScalarAttr<long long>(model, "dofs_per_pose", H5T_NATIVE_LLONG).value_or(0);
    a.nVertices = readScalarAttr<long long>(model, "n_vertices", H5T_NATIVE_LLONG).value_or(0);
    a.nEdges = readScalarAttr<long long>(model, "n_edges", H5T_NATIVE_LLONG).value_or(0);
    a.nRods = readScalarAttr<long long>(model, "n_rods", H5T_NATIVE_LLONG).value_or(0);
    a.nConnections = readScalarAttr<long long>(model, "n_connections", H5T_NATIVE_LLONG).value_or(0);
    a.planar = readScalarAttr<int>(model, "planar", H5T_NATIVE_INT).value_or(0);
  }
  if (exists(file, "rest/positions")) a.restPositions = readMatrix<3>(file, "rest/positions", path);
  if (exists(file, "design/radii")) a.radii = readMatrix<2>(file, "design/radii", path);
  if (exists(file, "design/initial_radii")) a.initialRadii = readMatrix<2>(file, "design/initial_radii", path);
  if (exists(file, "design/control_points")) {
    Hid cpg(H5Gopen2(file, "design/control_points", H5P_DEFAULT), H5Gclose);
    ArchiveControlPoints c;
    if (exists(cpg, "radii")) c.radii = readMatrix<2>(cpg, "radii", path);
    if (exists(cpg, "rest_displacement")) c.restDisplacement = readMatrix<3>(cpg, "rest_displacement", path);
    if (exists(cpg, "rod")) c.rod = readInts<int>(cpg, "rod", H5T_NATIVE_INT, path);
    if (exists(cpg, "arc_fraction")) c.arcFraction = readVector(cpg, "arc_fraction", path);
    if (exists(cpg, "vertex")) c.vertex = readInts<int>(cpg, "vertex", H5T_NATIVE_INT, path);
    a.controlPoints = std::move(c);
  }
  if (exists(file, "poses")) {
    Hid poses(H5Gopen2(file, "poses", H5P_DEFAULT), H5Gclose);
    std::vector<std::string> names;
    if (H5Literate(poses, H5_INDEX_CRT_ORDER, H5_ITER_INC, nullptr, collectName, &names) < 0) {
      names.clear();
      H5Literate(poses, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectName, &names);
    }
    for (const std::string& n : names) {
      ArchivePose p;
      p.name = n;
      Hid g(H5Gopen2(poses, n.c_str(), H5P_DEFAULT), H5Gclose);
      p.positions = readMatrix<3>(g, "positions", path);
      if (exists(g, "twist")) {
        std::vector<hsize_t> dims;
        std::vector<double> t = readDoubles(g, "twist", dims, path);
        p.twist = Eigen::Map<Eigen::VectorXd>(t.data(), t.size());
      }
      if (exists(g, "target")) p.target = readMatrix<3>(g, "target", path);
      p.residualNorm = readScalarAttr<double>(g, "residual_norm", H5T_NATIVE_DOUBLE).value_or(0.0);
      p.rmsError = readScalarAttr<double>(g, "rms_error", H5T_NATIVE_DOUBLE);
      p.status = readStringAttr(g, "status", path);
      p.iterations = (int)readScalarAttr<long long>(g, "iterations", H5T_NATIVE_LLONG).value_or(0);
      p.timeSeconds = readScalarAttr<double>(g, "time_s", H5T_NATIVE_DOUBLE).value_or(0.0);
      p.outOfPlaneStable = readScalarAttr<int>(g, "out_of_plane_stable", H5T_NATIVE_INT).value_or(-1);
      if (exists(g, "initial_positions")) p.initialPositions = readMatrix<3>(g, "initial_positions", path);
      p.equilibriumGap = readScalarAttr<double>(g, "equilibrium_gap", H5T_NATIVE_DOUBLE);
      a.poses.push_back(std::move(p));
    }
  }
  if (exists(file, "frames")) {
    Hid frames(H5Gopen2(file, "frames", H5P_DEFAULT), H5Gclose);
    std::vector<std::string> names;
    H5Literate(frames, H5_INDEX_NAME, H5_ITER_INC, nullptr, collectName, &names);
    for (const std::string& n : names) {
      ArchiveFrames f;
      f.name = n;
      Hid g(H5Gopen2(frames, n.c_str(), H5P_DEFAULT), H5Gclose);
      std::vector<hsize_t> dims;
      std::vector<double> d = readDoubles(g, "positions", dims, path);
      if (dims.size() == 3 && dims[2] == 3) {
        for (hsize_t t = 0; t < dims[0]; ++t) {
          MatX3 m(dims[1], 3);
          std::copy(d.begin() + t * dims[1] * 3, d.begin() + (t + 1) * dims[1] * 3, m.data());
          f.positions.push_back(std::move(m));
        }
      }
      if (exists(g, "time")) {
        std::vector<double> t = readDoubles(g, "time", dims, path);
        f.time = Eigen::Map<Eigen::VectorXd>(t.data(), t.size());
      }
      a.frames.push_back(std::move(f));
    }
  }
  if (exists(file, "history")) {
    ArchiveHistory h;
    Hid hg(H5Gopen2(file, "history", H5P_DEFAULT), H5Gclose);
    h.iteration = readInts<long long>(hg, "iteration", H5T_NATIVE_LLONG, path);
    h.timeSeconds = readVector(hg, "time_s", path);
    h.objective = readVector(hg, "objective", path);
    h.rmsError = readVector(hg, "rms_error", path);
    if (exists(hg, "level")) h.level = readInts<long long>(hg, "level", H5T_NATIVE_LLONG, path);
    if (exists(hg, "constraint_violation")) h.constraintViolation = readVector(hg, "constraint_violation", path);
    if (exists(hg, "gradient_norm")) h.gradientNorm = readVector(hg, "gradient_norm", path);
    if (exists(hg, "phase")) h.phase = readStrings(hg, "phase", path);
    a.history = std::move(h);
  }
  return a;
}

}  // namespace rodmesh
