// io/vtk_writer: document structure checks and the all-or-nothing FileSet.
// The files themselves are read back with VTK in tests/cli/visualization_cli_test.cc.
#include "io/vtk_writer.hh"

#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace rodmesh::vtk {
namespace {

std::vector<std::string> entries(const std::string& dir) {
  std::vector<std::string> out;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (n != "." && n != "..") out.push_back(n);
    }
    closedir(d);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class FileSetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char t[] = "/tmp/rodmesh_vtk_writer_XXXXXX";
    ASSERT_NE(mkdtemp(t), nullptr);
    dir_ = t;
  }
  void TearDown() override { std::system(("rm -rf '" + dir_ + "'").c_str()); }
  std::string dir_;
};

TEST(VtkWriter, DoublesRoundTrip) {
  for (double v : {0.1, 1.0 / 3.0, -2.5187804946376346e-06, 1e-300, 0.0, 123456789.0})
    EXPECT_EQ(std::stod(formatDouble(v)), v) << formatDouble(v);
}

TEST(VtkWriter, XmlEscape) { EXPECT_EQ(xmlEscape("a<b & \"c\">'d'"), "a&lt;b &amp; &quot;c&quot;&gt;&apos;d&apos;"); }

TEST(VtkWriter, RejectsInconsistentPolyData) {
  PolyLines d;
  d.points = {0, 0, 0, 1, 0, 0, 2, 0, 0};
  d.lines = {{0, 1, 2}};
  EXPECT_NO_THROW(polyDataXml(d));
  PolyLines bad = d;
  bad.lines = {{0, 3}};
  EXPECT_THROW(polyDataXml(bad), std::invalid_argument) << "a line through a missing point";
  bad = d;
  bad.pointData = {{"radius", 1, {1.0, 2.0}}};
  EXPECT_THROW(polyDataXml(bad), std::invalid_argument) << "a point array one value short";
  bad = d;
  bad.cellIntData = {{"rod", {0, 1}}};
  EXPECT_THROW(polyDataXml(bad), std::invalid_argument) << "two cell values for one line";
  bad = d;
  bad.points.pop_back();
  EXPECT_THROW(polyDataXml(bad), std::invalid_argument) << "points not V x 3";
}

TEST_F(FileSetTest, CommitWritesEveryFile) {
  FileSet s;
  s.add(dir_ + "/a.vtp", "A");
  s.add(dir_ + "/b.pvd", "B");
  EXPECT_TRUE(entries(dir_).empty()) << "nothing is written before commit";
  s.commit();
  EXPECT_EQ(entries(dir_), (std::vector<std::string>{"a.vtp", "b.pvd"}));
  EXPECT_EQ(slurp(dir_ + "/a.vtp"), "A");
  EXPECT_EQ(slurp(dir_ + "/b.pvd"), "B");
}

TEST_F(FileSetTest, AFileThatCannotBeWrittenLeavesNothing) {
  std::ofstream(dir_ + "/a.vtp") << "old";
  FileSet s;
  s.add(dir_ + "/a.vtp", "new");
  s.add(dir_ + "/missing/b.vtp", "B");
  EXPECT_THROW(s.commit(), std::runtime_error);
  EXPECT_EQ(entries(dir_), (std::vector<std::string>{"a.vtp"})) << "no temporary file left";
  EXPECT_EQ(slurp(dir_ + "/a.vtp"), "old") << "an existing file is kept when the set fails";
}

TEST_F(FileSetTest, DestroyedWithoutCommitWritesNothing) {
  {
    FileSet s;
    s.add(dir_ + "/a.vtp", "A");
  }
  EXPECT_TRUE(entries(dir_).empty());
}

}  // namespace
}  // namespace rodmesh::vtk
