// Result archive (contract §3): round trip, atomic writing, clear rejection of
// files that are not rodmesh archives.
#include "io/archive.hh"
#include "io/interrupt.hh"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <dirent.h>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace rodmesh {
namespace {

// A fresh temporary directory, removed (with its files) at the end.
class TempDir {
 public:
  TempDir() {
    char t[] = "/tmp/rodmesh_archive_test_XXXXXX";
    if (!mkdtemp(t)) throw std::runtime_error("mkdtemp failed");
    path_ = t;
  }
  ~TempDir() {
    for (const std::string& f : files()) {
      std::string p = path_ + "/" + f;
      if (std::remove(p.c_str()) != 0) rmdir(p.c_str());
    }
    rmdir(path_.c_str());
  }
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }
  std::vector<std::string> files() const {
    std::vector<std::string> out;
    if (DIR* d = opendir(path_.c_str())) {
      while (dirent* e = readdir(d)) {
        std::string n = e->d_name;
        if (n != "." && n != "..") out.push_back(n);
      }
      closedir(d);
    }
    return out;
  }

 private:
  std::string path_;
};

bool fileExists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

MatX3 randomX3(int rows, double scale) {
  MatX3 m = MatX3::Random(rows, 3) * scale;
  return m;
}

Archive fullArchive() {
  Archive a;
  a.version = "9.9.9-test";
  a.command = "optimize";
  a.status = "not_converged";
  a.sceneJson = "{\n  \"format\": \"rodmesh-scene/1\",\n  \"note\": \"unicode \xc3\xa9\\u00e9 and \\\"quotes\\\"\"\n}\n";
  a.effects = "stretch,bend,twist";
  a.effectsReason = "stretch: on (always); twist: on (the scene is not planar)";
  a.dofsPerPose = 123;
  a.nVertices = 5;
  a.nEdges = 4;
  a.nRods = 1;
  a.nConnections = 0;
  a.planar = 0;
  a.restPositions = randomX3(5, 0.01);
  a.radii = MatX2::Random(5, 2).cwiseAbs() * 1e-3;
  a.initialRadii = MatX2::Constant(5, 2, 2e-3);
  ArchivePose p0;
  p0.name = "pull_left";
  p0.positions = randomX3(5, 0.02);
  p0.twist = Eigen::VectorXd::Random(4);
  p0.target = randomX3(5, 0.02);
  p0.residualNorm = 1.5e-9;
  p0.rmsError = 3.25e-4;
  p0.status = "converged";
  p0.iterations = 7;
  p0.timeSeconds = 0.125;
  p0.initialPositions = randomX3(5, 0.02);
  p0.equilibriumGap = 2.5e-9;
  ArchivePose p1;  // no twist, no target, no rms
  p1.name = "a_second pose";
  p1.positions = randomX3(5, 0.02);
  p1.residualNorm = 2.0;
  p1.status = "not_converged";
  p1.iterations = 100;
  // Pose names out of alphabetical order: readers must keep scene order.
  ArchivePose p2;
  p2.name = "0_first_alphabetically";
  p2.positions = randomX3(5, 0.02);
  a.poses = {p0, p1, p2};
  ArchiveFrames f;
  f.name = "pull_left";
  f.time = Eigen::VectorXd::LinSpaced(3, 0.0, 0.2);
  f.positions = {randomX3(5, 1.0), randomX3(5, 1.0), randomX3(5, 1.0)};
  a.frames = {f};
  ArchiveHistory h;
  h.iteration = {0, 1, 2};
  h.timeSeconds = {0.0, 0.5, 1.25};
  h.objective = {10.0, 5.0, 4.5};
  h.rmsError = {1e-3, 5e-4, 4e-4};
  h.level = {0, 1, 2};
  h.constraintViolation = {1e-3, 1e-6, 1e-9};
  h.gradientNorm = {3.0, 0.5, 1e-4};
  h.phase = {"radii", "rest_shape", "joint \xc3\xa9"};
  a.history = h;
  ArchiveControlPoints c;  // one rod of 5 vertices, 4 control points: 2 shared ends, 2 interior
  c.radii = MatX2::Random(4, 2).cwiseAbs() * 1e-3;
  c.restDisplacement = MatX3::Random(4, 3) * 1e-4;
  c.rod = {-1, 0, 0, -1};
  c.arcFraction = {0.0, 1.0 / 3.0, 2.0 / 3.0, 0.0};
  c.vertex = {0, -1, -1, 4};
  c.radiusBounds = ArchiveControlPoints::RadiusBounds{5e-4, 2e-3, 3, 2, 0.75, -0.25};
  a.controlPoints = c;
  a.optimize = ArchiveOptimizeSummary{"sand", 42, 12.5, "stopped at --max-iter 42"};
  a.extraRootAttributes["solver"] = "ipopt 3.11";
  return a;
}

TEST(Archive, RoundTripsEveryField) {
  TempDir dir;
  const Archive a = fullArchive();
  const std::string path = dir / "out.h5";
  writeArchive(a, path);
  ASSERT_TRUE(fileExists(path));
  EXPECT_EQ(dir.files(), std::vector<std::string>{"out.h5"}) << "no temporary file left behind";

  const Archive b = readArchive(path);
  EXPECT_EQ(b.format, "rodmesh-archive/1");
  EXPECT_EQ(b.version, a.version);
  EXPECT_EQ(b.command, a.command);
  EXPECT_EQ(b.status, a.status);
  EXPECT_EQ(b.sceneJson, a.sceneJson);
  EXPECT_EQ(b.effects, a.effects);
  EXPECT_EQ(b.effectsReason, a.effectsReason);
  EXPECT_EQ(b.dofsPerPose, a.dofsPerPose);
  EXPECT_EQ(b.nVertices, a.nVertices);
  EXPECT_EQ(b.nEdges, a.nEdges);
  EXPECT_EQ(b.nRods, a.nRods);
  EXPECT_EQ(b.nConnections, a.nConnections);
  EXPECT_EQ(b.planar, a.planar);
  EXPECT_EQ(b.restPositions, a.restPositions);
  EXPECT_EQ(b.radii, a.radii);
  ASSERT_TRUE(b.initialRadii.has_value());
  EXPECT_EQ(*b.initialRadii, *a.initialRadii);

  ASSERT_EQ(b.poses.size(), a.poses.size());
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    SCOPED_TRACE("pose " + a.poses[i].name);
    const ArchivePose &x = a.poses[i], &y = b.poses[i];
    EXPECT_EQ(y.name, x.name) << "poses come back in the order written";
    EXPECT_EQ(y.positions, x.positions);
    EXPECT_EQ(y.twist.size(), x.twist.size());
    if (x.twist.size()) {
      EXPECT_EQ(y.twist, x.twist);
    }
    EXPECT_EQ(y.target.rows(), x.target.rows());
    if (x.target.rows()) {
      EXPECT_EQ(y.target, x.target);
    }
    EXPECT_EQ(y.residualNorm, x.residualNorm);
    EXPECT_EQ(y.rmsError, x.rmsError);
    EXPECT_EQ(y.status, x.status);
    EXPECT_EQ(y.iterations, x.iterations);
    EXPECT_EQ(y.timeSeconds, x.timeSeconds);
    EXPECT_EQ(y.initialPositions.rows(), x.initialPositions.rows());
    if (x.initialPositions.rows()) {
      EXPECT_EQ(y.initialPositions, x.initialPositions);
    }
    EXPECT_EQ(y.equilibriumGap, x.equilibriumGap);
  }

  ASSERT_EQ(b.frames.size(), 1u);
  EXPECT_EQ(b.frames[0].name, "pull_left");
  EXPECT_EQ(b.frames[0].time, a.frames[0].time);
  ASSERT_EQ(b.frames[0].positions.size(), 3u);
  for (int t = 0; t < 3; ++t) EXPECT_EQ(b.frames[0].positions[t], a.frames[0].positions[t]);

  ASSERT_TRUE(b.history.has_value());
  EXPECT_EQ(b.history->iteration, a.history->iteration);
  EXPECT_EQ(b.history->timeSeconds, a.history->timeSeconds);
  EXPECT_EQ(b.history->objective, a.history->objective);
  EXPECT_EQ(b.history->rmsError, a.history->rmsError);
  EXPECT_EQ(b.history->level, a.history->level);
  EXPECT_EQ(b.history->constraintViolation, a.history->constraintViolation);
  EXPECT_EQ(b.history->gradientNorm, a.history->gradientNorm);
  EXPECT_EQ(b.history->phase, a.history->phase);

  ASSERT_TRUE(b.controlPoints.has_value());
  EXPECT_EQ(b.controlPoints->radii, a.controlPoints->radii);
  EXPECT_EQ(b.controlPoints->restDisplacement, a.controlPoints->restDisplacement);
  EXPECT_EQ(b.controlPoints->rod, a.controlPoints->rod);
  EXPECT_EQ(b.controlPoints->arcFraction, a.controlPoints->arcFraction);
  EXPECT_EQ(b.controlPoints->vertex, a.controlPoints->vertex);
  ASSERT_TRUE(b.controlPoints->radiusBounds.has_value());
  EXPECT_EQ(b.controlPoints->radiusBounds->min, 5e-4);
  EXPECT_EQ(b.controlPoints->radiusBounds->max, 2e-3);
  EXPECT_EQ(b.controlPoints->radiusBounds->atMin, 3);
  EXPECT_EQ(b.controlPoints->radiusBounds->atMax, 2);
  EXPECT_EQ(b.controlPoints->radiusBounds->minElasticity, 0.75);
  EXPECT_EQ(b.controlPoints->radiusBounds->maxElasticity, -0.25);

  ASSERT_TRUE(b.optimize.has_value());
  EXPECT_EQ(b.optimize->method, "sand");
  EXPECT_EQ(b.optimize->iterations, 42);
  EXPECT_EQ(b.optimize->timeSeconds, 12.5);
  EXPECT_EQ(b.optimize->message, "stopped at --max-iter 42");
}

// The HDF5 class of an attribute or dataset (numbers as numbers, for h5py and friends).
H5T_class_t attributeClass(hid_t f, const char* object, const char* name) {
  hid_t attr = H5Aopen_by_name(f, object, name, H5P_DEFAULT, H5P_DEFAULT);
  if (attr < 0) return H5T_NO_CLASS;
  hid_t t = H5Aget_type(attr);
  const H5T_class_t c = H5Tget_class(t);
  H5Tclose(t);
  H5Aclose(attr);
  return c;
}
H5T_class_t datasetClass(hid_t f, const char* name) {
  hid_t ds = H5Dopen2(f, name, H5P_DEFAULT);
  if (ds < 0) return H5T_NO_CLASS;
  hid_t t = H5Dget_type(ds);
  const H5T_class_t c = H5Tget_class(t);
  H5Tclose(t);
  H5Dclose(ds);
  return c;
}

TEST(Archive, OptimizePartsHaveTheirTypes) {
  TempDir dir;
  writeArchive(fullArchive(), dir / "o.h5");
  hid_t f = H5Fopen((dir / "o.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  EXPECT_EQ(attributeClass(f, "/", "method"), H5T_STRING);
  EXPECT_EQ(attributeClass(f, "/", "iterations"), H5T_INTEGER);
  EXPECT_EQ(attributeClass(f, "/", "time_s"), H5T_FLOAT);
  EXPECT_EQ(attributeClass(f, "/", "message"), H5T_STRING);
  EXPECT_EQ(attributeClass(f, "poses/pull_left", "equilibrium_gap"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "poses/pull_left/initial_positions"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "history/iteration"), H5T_INTEGER);
  EXPECT_EQ(datasetClass(f, "history/level"), H5T_INTEGER);
  EXPECT_EQ(datasetClass(f, "history/objective"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "history/constraint_violation"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "history/gradient_norm"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "history/phase"), H5T_STRING);
  EXPECT_EQ(datasetClass(f, "design/control_points/radii"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "design/control_points/rest_displacement"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "design/control_points/rod"), H5T_INTEGER);
  EXPECT_EQ(datasetClass(f, "design/control_points/arc_fraction"), H5T_FLOAT);
  EXPECT_EQ(datasetClass(f, "design/control_points/vertex"), H5T_INTEGER);
  // Poses without optimize data carry none.
  EXPECT_EQ(H5Lexists(f, "poses/a_second pose/initial_positions", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Aexists_by_name(f, "poses/a_second pose", "equilibrium_gap", H5P_DEFAULT), 0);
  H5Fclose(f);
}

TEST(Archive, ReadsAHistoryWrittenAsFloat64WithoutTheNewerDatasets) {
  // Archives written before /history/iteration became int64 (and before level,
  // constraint_violation, gradient_norm, phase) still read.
  TempDir dir;
  Archive a = fullArchive();
  a.history = ArchiveHistory{};
  a.history->iteration = {0, 1};
  a.history->timeSeconds = {0.0, 1.0};
  a.history->objective = {2.0, 1.0};
  a.history->rmsError = {1e-3, 1e-4};
  writeArchive(a, dir / "h.h5");
  hid_t f = H5Fopen((dir / "h.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  ASSERT_GE(H5Ldelete(f, "history/iteration", H5P_DEFAULT), 0);
  const hsize_t n = 2;
  const double it[2] = {0.0, 1.0};
  hid_t space = H5Screate_simple(1, &n, nullptr);
  hid_t ds = H5Dcreate2(f, "history/iteration", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, it);
  H5Dclose(ds);
  H5Sclose(space);
  H5Fclose(f);
  const Archive b = readArchive(dir / "h.h5");
  ASSERT_TRUE(b.history.has_value());
  EXPECT_EQ(b.history->iteration, (std::vector<long long>{0, 1}));
  EXPECT_TRUE(b.history->level.empty());
  EXPECT_TRUE(b.history->phase.empty());
}

TEST(Archive, InconsistentOptimizePartsThrowAndWriteNothing) {
  TempDir dir;
  {
    Archive a = fullArchive();
    a.history->objective.pop_back();
    EXPECT_THROW(writeArchive(a, dir / "x.h5"), std::runtime_error);
  }
  {
    Archive a = fullArchive();
    a.history->phase = {"radii"};
    EXPECT_THROW(writeArchive(a, dir / "x.h5"), std::runtime_error);
  }
  {
    Archive a = fullArchive();
    a.controlPoints->arcFraction.push_back(0.5);
    EXPECT_THROW(writeArchive(a, dir / "x.h5"), std::runtime_error);
  }
  {
    Archive a = fullArchive();
    a.controlPoints->radii = MatX2::Zero(3, 2);
    EXPECT_THROW(writeArchive(a, dir / "x.h5"), std::runtime_error);
  }
  {
    Archive a = fullArchive();
    a.poses[0].initialPositions = MatX3::Zero(4, 3);
    EXPECT_THROW(writeArchive(a, dir / "x.h5"), std::runtime_error);
  }
  EXPECT_TRUE(dir.files().empty());
}

TEST(Archive, OptionalPartsStayAbsent) {
  TempDir dir;
  Archive a = fullArchive();
  a.command = "simulate";
  a.status = "converged";
  a.initialRadii.reset();
  a.history.reset();
  a.controlPoints.reset();
  a.optimize.reset();
  a.frames.clear();
  for (ArchivePose& p : a.poses) {
    p.twist.resize(0);
    p.target.resize(0, 3);
    p.rmsError.reset();
    p.initialPositions.resize(0, 3);
    p.equilibriumGap.reset();
  }
  writeArchive(a, dir / "s.h5");
  const Archive b = readArchive(dir / "s.h5");
  EXPECT_FALSE(b.initialRadii.has_value());
  EXPECT_FALSE(b.history.has_value());
  EXPECT_FALSE(b.controlPoints.has_value());
  EXPECT_FALSE(b.optimize.has_value());
  EXPECT_TRUE(b.frames.empty());
  ASSERT_EQ(b.poses.size(), 3u);
  for (const ArchivePose& p : b.poses) {
    EXPECT_EQ(p.twist.size(), 0);
    EXPECT_EQ(p.target.rows(), 0);
    EXPECT_FALSE(p.rmsError.has_value());
    EXPECT_EQ(p.initialPositions.rows(), 0);
    EXPECT_FALSE(p.equilibriumGap.has_value());
  }

  // And they are really absent from the file, not written empty.
  hid_t f = H5Fopen((dir / "s.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  EXPECT_EQ(H5Lexists(f, "design/initial_radii", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(f, "history", H5P_DEFAULT), 0);
  EXPECT_GT(H5Lexists(f, "poses/pull_left", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(f, "poses/pull_left/twist", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(f, "poses/pull_left/target", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Aexists_by_name(f, "poses/pull_left", "rms_error", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(f, "design/control_points", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(f, "poses/pull_left/initial_positions", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Aexists_by_name(f, "poses/pull_left", "equilibrium_gap", H5P_DEFAULT), 0);
  for (const char* key : {"method", "iterations", "time_s", "message"}) EXPECT_EQ(H5Aexists(f, key), 0) << key;
  H5Fclose(f);
}

TEST(Archive, OverwritesAnExistingArchive) {
  TempDir dir;
  Archive a = fullArchive();
  writeArchive(a, dir / "out.h5");
  a.status = "converged";
  a.poses.resize(1);
  writeArchive(a, dir / "out.h5");
  const Archive b = readArchive(dir / "out.h5");
  EXPECT_EQ(b.status, "converged");
  EXPECT_EQ(b.poses.size(), 1u);
  EXPECT_EQ(dir.files(), std::vector<std::string>{"out.h5"});
}

TEST(Archive, NonexistentDirectoryThrowsAndCreatesNothing) {
  TempDir dir;
  const std::string path = dir / "missing/sub/out.h5";
  EXPECT_THROW(writeArchive(fullArchive(), path), std::runtime_error);
  EXPECT_FALSE(fileExists(path));
  EXPECT_TRUE(dir.files().empty());
}

TEST(Archive, FailureHalfwayLeavesNoPartialFile) {
  // A pose name with '/' makes HDF5 fail after the temporary file was created
  // and partly written.
  TempDir dir;
  Archive a = fullArchive();
  a.poses[1].name = "no/such/group";
  const std::string path = dir / "out.h5";
  EXPECT_THROW(writeArchive(a, path), std::runtime_error);
  EXPECT_FALSE(fileExists(path));
  EXPECT_TRUE(dir.files().empty()) << "temporary file left behind: " << (dir.files().empty() ? "" : dir.files()[0]);
}

TEST(Archive, FailureKeepsThePreviousArchiveIntact) {
  TempDir dir;
  const std::string path = dir / "out.h5";
  Archive good = fullArchive();
  writeArchive(good, path);
  Archive bad = fullArchive();
  bad.status = "converged";
  bad.poses[0].name = "x/y";
  EXPECT_THROW(writeArchive(bad, path), std::runtime_error);
  const Archive b = readArchive(path);
  EXPECT_EQ(b.status, good.status);
  EXPECT_EQ(b.poses.size(), good.poses.size());
  EXPECT_EQ(dir.files(), std::vector<std::string>{"out.h5"});
}

TEST(Archive, RenameOntoADirectoryFailsCleanly) {
  TempDir dir;
  const std::string path = dir / "taken";
  ASSERT_EQ(mkdir(path.c_str(), 0755), 0);
  ASSERT_TRUE(std::ofstream(path + "/keep").good());
  EXPECT_THROW(writeArchive(fullArchive(), path), std::runtime_error);
  EXPECT_EQ(dir.files(), std::vector<std::string>{"taken"}) << "temporary file left behind";
  std::remove((path + "/keep").c_str());
}

std::string readError(const std::string& path) {
  try {
    readArchive(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "readArchive accepted " << path;
  return "";
}

TEST(Archive, RejectsAMissingFile) {
  TempDir dir;
  const std::string path = dir / "nothing.h5";
  const std::string msg = readError(path);
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
}

TEST(Archive, RejectsANonHdf5File) {
  TempDir dir;
  const std::string path = dir / "scene.json";
  std::ofstream(path) << "{\"format\": \"rodmesh-scene/1\"}\n";
  const std::string msg = readError(path);
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find("HDF5"), std::string::npos) << msg;
}

TEST(Archive, RejectsAnEmptyFile) {
  TempDir dir;
  const std::string path = dir / "empty.h5";
  std::ofstream(path).flush();
  const std::string msg = readError(path);
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
}

TEST(Archive, RejectsAnHdf5FileWithoutTheFormatAttribute) {
  TempDir dir;
  const std::string path = dir / "other.h5";
  {
    hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    hid_t g = H5Gcreate2(f, "poses", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    H5Fclose(f);
  }
  const std::string msg = readError(path);
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find("format"), std::string::npos) << msg;
}

// Writes a fixed-length string attribute, as numpy 'S' strings (h5py) or
// Fortran/Matlab tools store them.
void writeFixedStringAttr(hid_t obj, const char* name, const std::string& value, H5T_str_t pad, std::size_t size) {
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, size);
  H5Tset_strpad(type, pad);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  std::string buf = value;
  buf.resize(size, '\0');
  H5Awrite(attr, type, buf.data());
  H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
}

TEST(Archive, ReadsFixedLengthStringAttributes) {
  TempDir dir;
  for (H5T_str_t pad : {H5T_STR_NULLPAD, H5T_STR_NULLTERM}) {
    SCOPED_TRACE(pad == H5T_STR_NULLPAD ? "null-padded" : "null-terminated");
    const std::string path = dir / "fixed.h5";
    {
      // A complete archive whose root strings are then rewritten fixed-length.
      writeArchive(fullArchive(), path);
      hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      ASSERT_GE(f, 0);
      for (const char* name : {"format", "status", "command"}) ASSERT_GE(H5Adelete(f, name), 0);
      // Null-padded strings may fill their size exactly; null-terminated ones
      // need one more byte.
      const std::size_t extra = pad == H5T_STR_NULLPAD ? 0 : 1;
      writeFixedStringAttr(f, "format", "rodmesh-archive/1", pad, 17 + extra);
      writeFixedStringAttr(f, "status", "converged", pad, 9 + extra);
      writeFixedStringAttr(f, "command", "simulate", pad, 20);
      H5Fclose(f);
    }
    Archive a;
    ASSERT_NO_THROW(a = readArchive(path));
    EXPECT_EQ(a.format, "rodmesh-archive/1");
    EXPECT_EQ(a.status, "converged");
    EXPECT_EQ(a.command, "simulate");
    std::remove(path.c_str());
  }
}

TEST(Archive, RejectsAnHdf5FileWithAnotherFormat) {
  TempDir dir;
  const std::string path = dir / "other.h5";
  Archive a = fullArchive();
  a.format = "someone-else/3";
  writeArchive(a, path);
  const std::string msg = readError(path);
  EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find("someone-else/3"), std::string::npos) << msg;
}

// ---------------------------------------------------------------- interrupts, stale temporary files

// A PID that no longer exists: a child that exited and was reaped.
pid_t deadPid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  int status = 0;
  waitpid(pid, &status, 0);
  return pid;
}

std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

TEST(ArchiveInterrupt, StaleTempFilesOfDeadProcessesAreRemoved) {
  TempDir dir;
  const std::string stale = "out.h5.tmp." + std::to_string(deadPid());
  const std::string live = "out.h5.tmp." + std::to_string(getppid());  // our parent is alive
  const std::string otherArchive = "other.h5.tmp." + std::to_string(deadPid());
  const std::string notAPid = "out.h5.tmp.12ab";
  for (const std::string& n : {stale, live, otherArchive, notAPid}) std::ofstream(dir / n) << "partial";
  writeArchive(fullArchive(), dir / "out.h5");
  EXPECT_EQ(sorted(dir.files()), sorted({"out.h5", live, otherArchive, notAPid}))
      << "only " << stale << " (dead writer, same archive) goes";
  EXPECT_EQ(removeStaleTempFiles(dir / "other.h5"), 1);
  EXPECT_EQ(removeStaleTempFiles(dir / "out.h5"), 0);
}

// Saves SIGINT / SIGTERM dispositions and restores them (and removes the flag handler) at the end.
class SignalState {
 public:
  SignalState() {
    sigaction(SIGINT, nullptr, &int_);
    sigaction(SIGTERM, nullptr, &term_);
  }
  ~SignalState() {
    uninstallInterruptFlag();
    sigaction(SIGINT, &int_, nullptr);
    sigaction(SIGTERM, &term_, nullptr);
  }

 private:
  struct sigaction int_, term_;
};

TEST(ArchiveInterrupt, FlagIsSetBySigintOrSigtermAndTheProcessGoesOn) {
  SignalState keep;
  installInterruptFlag();
  installInterruptFlag();  // idempotent
  EXPECT_FALSE(interruptRequested());
  std::raise(SIGINT);
  EXPECT_TRUE(interruptRequested());
  EXPECT_EQ(interruptSignal(), SIGINT);
  clearInterruptRequest();
  EXPECT_FALSE(interruptRequested());
  std::raise(SIGTERM);
  EXPECT_EQ(interruptSignal(), SIGTERM);
  uninstallInterruptFlag();
  EXPECT_FALSE(interruptRequested());
}

TEST(ArchiveInterrupt, AWriteAfterTheFirstInterruptCompletesAndTheFlagHandlerComesBack) {
  SignalState keep;
  TempDir dir;
  installInterruptFlag();
  std::raise(SIGINT);  // the optimizer's stop request; it then writes its archive
  ASSERT_TRUE(interruptRequested());
  writeArchive(fullArchive(), dir / "out.h5");
  EXPECT_EQ(dir.files(), std::vector<std::string>{"out.h5"});
  EXPECT_EQ(readArchive(dir / "out.h5").optimize->method, "sand");
  EXPECT_TRUE(interruptRequested()) << "writing does not consume the request";
  clearInterruptRequest();
  std::raise(SIGTERM);  // handled by the flag handler again, not by the write's
  EXPECT_EQ(interruptSignal(), SIGTERM);
}

volatile std::sig_atomic_t g_seenSignal = 0;
void recordSignal(int sig) { g_seenSignal = sig; }

TEST(ArchiveInterrupt, PreviousHandlersAreRestoredAfterAWrite) {
  SignalState keep;
  TempDir dir;
  struct sigaction mine;
  std::memset(&mine, 0, sizeof mine);
  mine.sa_handler = recordSignal;
  sigemptyset(&mine.sa_mask);
  ASSERT_EQ(sigaction(SIGINT, &mine, nullptr), 0);
  std::signal(SIGTERM, SIG_IGN);
  writeArchive(fullArchive(), dir / "out.h5");
  struct sigaction now;
  sigaction(SIGINT, nullptr, &now);
  EXPECT_EQ(now.sa_handler, &recordSignal);
  sigaction(SIGTERM, nullptr, &now);
  EXPECT_EQ(now.sa_handler, SIG_IGN) << "an ignored signal stays ignored";
  g_seenSignal = 0;
  std::raise(SIGINT);
  EXPECT_EQ(g_seenSignal, SIGINT);
}

// True while this process writes the archive `path`: it holds an unnamed
// file (O_TMPFILE) in the directory of `path` open, or PATH.tmp.PID exists
// (file systems without O_TMPFILE).
bool writingArchive(const std::string& path) {
  const std::string dir = path.substr(0, path.find_last_of('/'));
  if (DIR* d = opendir("/proc/self/fd")) {
    bool found = false;
    while (dirent* e = readdir(d)) {
      char target[4096];
      const ssize_t n = readlink(("/proc/self/fd/" + std::string(e->d_name)).c_str(), target, sizeof target - 1);
      if (n > 0 && std::string(target, n).rfind(dir + "/#", 0) == 0) found = true;
    }
    closedir(d);
    if (found) return true;
  }
  return fileExists(path + ".tmp." + std::to_string(getpid()));
}

// In a death-test child: a thread sends `sig` to the process as soon as it
// writes `path` (the write is then held open by RODMESH_TEST_SLOW_WRITE).
void signalOnceTheTempFileExists(const std::string& path, int sig) {
  std::thread([path, sig] {
    for (int i = 0; i < 4000 && !writingArchive(path); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    kill(getpid(), sig);
  }).detach();
}

TEST(ArchiveInterruptDeathTest, SigintDuringAWriteRemovesTheTemporaryFileAndExits130) {
  TempDir dir;
  const std::string path = dir / "out.h5";
  EXPECT_EXIT(
      {
        setenv("RODMESH_TEST_SLOW_WRITE", "30", 1);
        signalOnceTheTempFileExists(path, SIGINT);
        writeArchive(fullArchive(), path);
        std::exit(0);
      },
      ::testing::ExitedWithCode(130), "");
  EXPECT_TRUE(dir.files().empty()) << "neither out.h5 nor its temporary file";
}

TEST(ArchiveInterruptDeathTest, SigtermDuringAWriteRemovesTheTemporaryFileAndExits143) {
  TempDir dir;
  const std::string path = dir / "out.h5";
  EXPECT_EXIT(
      {
        setenv("RODMESH_TEST_SLOW_WRITE", "30", 1);
        signalOnceTheTempFileExists(path, SIGTERM);
        writeArchive(fullArchive(), path);
        std::exit(0);
      },
      ::testing::ExitedWithCode(143), "");
  EXPECT_TRUE(dir.files().empty());
}

TEST(ArchiveInterruptDeathTest, SigkillDuringAWriteLeavesNoFile) {
  // The archive is written into an unnamed file: nothing remains of a writer
  // killed in the middle, not even by SIGKILL.
  TempDir dir;
  const std::string path = dir / "out.h5";
  EXPECT_EXIT(
      {
        setenv("RODMESH_TEST_SLOW_WRITE", "30", 1);
        signalOnceTheTempFileExists(path, SIGKILL);
        writeArchive(fullArchive(), path);
        std::exit(0);
      },
      ::testing::KilledBySignal(SIGKILL), "");
  EXPECT_TRUE(dir.files().empty());
}

TEST(Archive, TheImageInMemoryIsTheFileWriteArchiveWrites) {
  TempDir dir;
  const Archive a = fullArchive();
  writeArchive(a, dir / "out.h5");
  const std::string image = writeArchiveImage(a);
  std::ifstream in(dir / "out.h5", std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(file.size(), image.size());
  const Archive b = readArchiveImage(image.data(), image.size(), "image");
  EXPECT_EQ(b.sceneJson, a.sceneJson);
  EXPECT_EQ(b.poses.size(), a.poses.size());
  EXPECT_EQ(b.frames[0].positions[2], a.frames[0].positions[2]);
}

TEST(ArchiveInterruptDeathTest, SecondSignalDuringTheFinalWriteRemovesTheTemporaryFile) {
  // optimize: the first SIGINT stops the optimizer, which writes its archive;
  // a SIGTERM during that write removes the temporary file and exits.
  TempDir dir;
  const std::string path = dir / "out.h5";
  EXPECT_EXIT(
      {
        installInterruptFlag();
        std::raise(SIGINT);
        if (!interruptRequested()) std::exit(3);
        setenv("RODMESH_TEST_SLOW_WRITE", "30", 1);
        signalOnceTheTempFileExists(path, SIGTERM);
        writeArchive(fullArchive(), path);
        std::exit(0);
      },
      ::testing::ExitedWithCode(143), "");
  EXPECT_TRUE(dir.files().empty());
}

TEST(ArchiveInterruptDeathTest, SecondSignalOutsideAWriteExitsAtOnce) {
  EXPECT_EXIT(
      {
        installInterruptFlag();
        std::raise(SIGINT);
        if (!interruptRequested()) std::exit(3);
        std::raise(SIGINT);
        std::exit(0);
      },
      ::testing::ExitedWithCode(130), "");
}

}  // namespace
}  // namespace rodmesh
