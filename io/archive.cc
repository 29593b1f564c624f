#include "io/archive.hh"

#include "io/hdf5_util.hh"
#include "io/interrupt.hh"

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <thread>

namespace rodmesh {
namespace {

using h5::Hid;
using h5::stringType;

void check(herr_t status, const std::string& what) {
  if (status < 0) throw std::runtime_error("HDF5 error while writing " + what);
}
hid_t checkId(hid_t id, const std::string& what) {
  if (id < 0) throw std::runtime_error("HDF5 error while writing " + what);
  return id;
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
    same(h.confirmedRms.size(), "confirmed_rms", true);
    same(h.gradientNorm.size(), "gradient_norm", true);
    same(h.phase.size(), "phase", true);
    same(h.cgIterations.size(), "cg_iterations", true);
    same(h.trustRadius.size(), "trust_radius", true);
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

// Writes every part of `a` into the open, empty file `file`.
void writeContents(const Archive& a, hid_t file) {
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
    if (o.evaluations >= 0) writeScalarAttr<long long>(file, "evaluations", o.evaluations, H5T_NATIVE_LLONG);
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
      if (c.radiusBounds) {
        const ArchiveControlPoints::RadiusBounds& b = *c.radiusBounds;
        writeScalarAttr<double>(cp, "radius_min", b.min, H5T_NATIVE_DOUBLE);
        writeScalarAttr<double>(cp, "radius_max", b.max, H5T_NATIVE_DOUBLE);
        writeScalarAttr<long long>(cp, "radii_at_min", b.atMin, H5T_NATIVE_LLONG);
        writeScalarAttr<long long>(cp, "radii_at_max", b.atMax, H5T_NATIVE_LLONG);
        writeScalarAttr<double>(cp, "elasticity_min", b.minElasticity, H5T_NATIVE_DOUBLE);
        writeScalarAttr<double>(cp, "elasticity_max", b.maxElasticity, H5T_NATIVE_DOUBLE);
      }
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
      if (p.stable >= 0) writeScalarAttr<int>(g, "stable", p.stable, H5T_NATIVE_INT);
      if (p.smallestEigenvalue)
        writeScalarAttr<double>(g, "smallest_eigenvalue", *p.smallestEigenvalue, H5T_NATIVE_DOUBLE);
      if (p.unloadedSmallestEigenvalue)
        writeScalarAttr<double>(g, "unloaded_smallest_eigenvalue", *p.unloadedSmallestEigenvalue, H5T_NATIVE_DOUBLE);
      if (p.imperfectionSensitive >= 0)
        writeScalarAttr<int>(g, "imperfection_sensitive", p.imperfectionSensitive, H5T_NATIVE_INT);
      if (p.imperfectionGap) writeScalarAttr<double>(g, "imperfection_gap", *p.imperfectionGap, H5T_NATIVE_DOUBLE);
      if (p.criticalPoints.rows() > 0)
        writeDoubles(g, "critical_points", p.criticalPoints.data(), {(hsize_t)p.criticalPoints.rows(), 3});
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
      writeDoubles(h, "constraint_violation", hs.constraintViolation.data(), {(hsize_t)hs.constraintViolation.size()});
    if (!hs.gradientNorm.empty())
      writeDoubles(h, "gradient_norm", hs.gradientNorm.data(), {(hsize_t)hs.gradientNorm.size()});
    if (!hs.phase.empty()) writeStrings(h, "phase", hs.phase);
    if (!hs.confirmedRms.empty())
      writeDoubles(h, "confirmed_rms", hs.confirmedRms.data(), {(hsize_t)hs.confirmedRms.size()});
    if (!hs.cgIterations.empty())
      writeInts<long long>(h, "cg_iterations", hs.cgIterations, H5T_STD_I64LE, H5T_NATIVE_LLONG);
    if (!hs.trustRadius.empty())
      writeDoubles(h, "trust_radius", hs.trustRadius.data(), {(hsize_t)hs.trustRadius.size()});
  }
}

// Archives up to this size are built in memory and written into an unnamed
// file; larger ones are written by HDF5 into a named temporary file.
constexpr std::size_t kInMemoryBytes = std::size_t(128) << 20;

// Bytes of numbers and text in an archive: its size, give or take metadata.
std::size_t estimatedBytes(const Archive& a) {
  std::size_t n = a.sceneJson.size() + 8 * (a.restPositions.size() + a.radii.size());
  if (a.initialRadii) n += 8 * a.initialRadii->size();
  for (const ArchivePose& p : a.poses)
    n += 8 * (p.positions.size() + p.twist.size() + p.target.size() + p.initialPositions.size());
  for (const ArchiveFrames& f : a.frames) {
    n += 8 * f.time.size();
    for (const MatX3& m : f.positions) n += 8 * m.size();
  }
  if (a.history) n += 64 * a.history->iteration.size();
  if (a.controlPoints) n += 64 * a.controlPoints->rod.size();
  return n;
}

// An unnamed file in a directory (O_TMPFILE): it has no name until linkAs(),
// so a process killed while writing it, even by SIGKILL, leaves nothing
// behind. ok() is false where the file system cannot make one.
class UnnamedFile {
 public:
  explicit UnnamedFile(const std::string& dir) {
#ifdef O_TMPFILE
    fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0666);
#endif
  }
  ~UnnamedFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  UnnamedFile(const UnnamedFile&) = delete;
  UnnamedFile& operator=(const UnnamedFile&) = delete;

  bool ok() const { return fd_ >= 0; }

  void write(const std::string& bytes, const std::string& what) {
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t w = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) throw std::runtime_error("cannot write " + what + ": " + std::strerror(errno));
      done += static_cast<std::size_t>(w);
    }
  }

  // Gives the complete file the name `path` (which must not exist).
  void linkAs(const std::string& path) {
    if (::linkat(fd_, "", AT_FDCWD, path.c_str(), AT_EMPTY_PATH) == 0) return;
    const std::string proc = "/proc/self/fd/" + std::to_string(fd_);
    if (::linkat(AT_FDCWD, proc.c_str(), AT_FDCWD, path.c_str(), AT_SYMLINK_FOLLOW) == 0) return;
    copyTo(path);  // neither link is allowed here (privileges, mounts): copy the bytes
  }

 private:
  void copyTo(const std::string& path) {
    const int out = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (out < 0) throw std::runtime_error("cannot create " + path + ": " + std::strerror(errno));
    char buf[1 << 16];
    off_t at = 0;
    while (true) {
      const ssize_t n = ::pread(fd_, buf, sizeof buf, at);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        ::close(out);
        throw std::runtime_error("cannot read the temporary archive: " + std::string(std::strerror(errno)));
      }
      if (n == 0) break;
      for (ssize_t done = 0; done < n;) {
        const ssize_t w = ::write(out, buf + done, static_cast<std::size_t>(n - done));
        if (w < 0 && errno == EINTR) continue;
        if (w < 0) {
          ::close(out);
          throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
        }
        done += w;
      }
      at += n;
    }
    if (::close(out) != 0) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
  }

  int fd_ = -1;
};

std::string directoryOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

}  // namespace

void writeArchive(const Archive& a, const std::string& path) {
  checkConsistent(a);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  removeStaleTempFiles(path);
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  // Until the end of this function SIGINT / SIGTERM unlink `tmp` (if it
  // exists by then) and exit.
  TempFileGuard guard(tmp);
  try {
    // Built in memory, written into an unnamed file, named `tmp` once
    // complete and renamed to `path`: no partial file ever has a name. Large
    // archives (or file systems without O_TMPFILE): HDF5 writes `tmp` itself.
    std::optional<UnnamedFile> unnamed;
    if (estimatedBytes(a) <= kInMemoryBytes) unnamed.emplace(directoryOf(path));
    if (unnamed && unnamed->ok()) {
      unnamed->write(writeArchiveImage(a), path);
      slowWriteHook();
      unnamed->linkAs(tmp);
    } else {
      {
        Hid file(checkId(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), tmp), H5Fclose);
        writeContents(a, file);
        check(H5Fflush(file, H5F_SCOPE_GLOBAL), tmp);
      }
      slowWriteHook();
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw std::runtime_error("cannot move " + tmp + " to " + path + ": " + std::strerror(errno));
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

std::string writeArchiveImage(const Archive& a) {
  checkConsistent(a);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  check(H5Pset_fapl_core(fapl, 1 << 20, 0), "an archive in memory");
  Hid file(checkId(H5Fcreate(h5::kMemoryFileName, H5F_ACC_TRUNC, H5P_DEFAULT, fapl), "an archive in memory"), H5Fclose);
  writeContents(a, file);
  check(H5Fflush(file, H5F_SCOPE_GLOBAL), "an archive in memory");
  const ssize_t size = H5Fget_file_image(file, nullptr, 0);
  if (size < 0) throw std::runtime_error("HDF5 error while writing an archive in memory");
  std::string image(static_cast<std::size_t>(size), '\0');
  if (H5Fget_file_image(file, image.data(), image.size()) != size)
    throw std::runtime_error("HDF5 error while writing an archive in memory");
  return image;
}

}  // namespace rodmesh
