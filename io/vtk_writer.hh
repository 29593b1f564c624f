// A small writer for VTK XML files (no VTK library needed): PolyData made of
// polylines (.vtp, ASCII) and ParaView collections (.pvd), plus a set of
// output files that appear together or not at all.
//
// Format references: "VTK File Formats", section "XML File Formats" (VTK
// User's Guide; PolyData piece with Points, Lines/connectivity+offsets,
// PointData, CellData), and ParaView's PVD collection ("VTKFile
// type=Collection", one DataSet per timestep/part).
//
// Floating-point values are written in the shortest form that reads back to
// the same double (std::to_chars), so a reader sees exactly the stored values.
#pragma once

#include <string>
#include <vector>

namespace rodmesh::vtk {

// A named array of `components` values per tuple, tuple-major.
struct FloatArray {
  std::string name;
  int components = 1;
  std::vector<double> values;  // tuples x components, written as Float64
};

struct IntArray {
  std::string name;
  std::vector<int> values;  // one component, written as Int32
};

// Points joined by polylines; point and cell (= polyline) arrays.
struct PolyLines {
  std::vector<double> points;           // V x 3, row-major
  std::vector<std::vector<int>> lines;  // point indices of each polyline
  std::vector<FloatArray> pointData;    // V tuples each
  std::vector<IntArray> cellIntData;    // one value per polyline
  std::vector<FloatArray> fieldData;    // whole-dataset values (e.g. TimeValue)
  std::string activeScalars;            // PointData Scalars= (optional)
  std::string activeVectors;            // PointData Vectors= (optional)
};

// The .vtp document. Throws std::invalid_argument if array sizes do not match
// the number of points or lines, or a line refers to a missing point.
std::string polyDataXml(const PolyLines& data);

// One DataSet of a .pvd collection; `file` is relative to the .pvd.
struct CollectionEntry {
  double timestep = 0.0;
  int part = 0;
  std::string name;  // optional, written as the `name` attribute (ParaView block name)
  std::string file;
};

std::string collectionXml(const std::vector<CollectionEntry>& entries);

// XML attribute/text escaping (& < > " ').
std::string xmlEscape(const std::string& s);

// Shortest round-trip decimal form of a double.
std::string formatDouble(double v);

// Output files written together: add() collects path and content; commit()
// writes each to PATH.tmp.PID-N next to it and, only once all are complete,
// renames them into place in the order they were added (add a collection
// last: it appears after its pieces). On any failure the temporary files are
// removed and std::runtime_error names the path; files already at the target
// paths before the call are left as they were. Nothing is written before
// commit(), and a FileSet destroyed without commit() writes nothing.
class FileSet {
 public:
  void add(const std::string& path, std::string content);
  void commit();
  const std::vector<std::string>& paths() const { return paths_; }

 private:
  std::vector<std::string> paths_;
  std::vector<std::string> contents_;
};

}  // namespace rodmesh::vtk
