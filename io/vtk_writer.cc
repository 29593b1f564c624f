#include "io/vtk_writer.hh"

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace rodmesh::vtk {

std::string formatDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

std::string xmlEscape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

namespace {

// Values on lines of `perLine` entries, indented.
template <class T, class F>
void putValues(std::string& o, const std::vector<T>& v, std::size_t perLine, F format) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i % perLine == 0)
      o += i == 0 ? "          " : "\n          ";
    else
      o += ' ';
    o += format(v[i]);
  }
  o += '\n';
}

void putFloatArray(std::string& o, const FloatArray& a, bool named = true) {
  o += "        <DataArray type=\"Float64\"";
  if (named) o += " Name=\"" + xmlEscape(a.name) + "\"";
  o += " NumberOfComponents=\"" + std::to_string(a.components) + "\" format=\"ascii\">\n";
  putValues(o, a.values, a.components == 1 ? 6 : static_cast<std::size_t>(a.components), formatDouble);
  o += "        </DataArray>\n";
}

template <class T>
void putIntArray(std::string& o, const char* type, const std::string& name, const std::vector<T>& v) {
  o += std::string("        <DataArray type=\"") + type + "\" Name=\"" + xmlEscape(name) + "\" format=\"ascii\">\n";
  putValues(o, v, 12, [](T x) { return std::to_string(x); });
  o += "        </DataArray>\n";
}

}  // namespace

std::string polyDataXml(const PolyLines& d) {
  if (d.points.size() % 3 != 0) throw std::invalid_argument("vtk: points are not V x 3");
  const std::size_t nv = d.points.size() / 3;
  const std::size_t nl = d.lines.size();
  for (const FloatArray& a : d.pointData)
    if (a.components < 1 || a.values.size() != nv * static_cast<std::size_t>(a.components))
      throw std::invalid_argument("vtk: point array '" + a.name + "' does not have one tuple per point");
  for (const IntArray& a : d.cellIntData)
    if (a.values.size() != nl)
      throw std::invalid_argument("vtk: cell array '" + a.name + "' does not have one value per line");
  std::vector<long long> connectivity, offsets;
  for (const std::vector<int>& line : d.lines) {
    for (int p : line) {
      if (p < 0 || static_cast<std::size_t>(p) >= nv)
        throw std::invalid_argument("vtk: a line refers to a missing point");
      connectivity.push_back(p);
    }
    offsets.push_back(static_cast<long long>(connectivity.size()));
  }

  std::string o;
  o.reserve(64 * (nv + connectivity.size()) + 1024);
  o += "<?xml version=\"1.0\"?>\n";
  o += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  o += "  <PolyData>\n";
  if (!d.fieldData.empty()) {
    o += "    <FieldData>\n";
    for (const FloatArray& a : d.fieldData) {
      // Field data arrays state their tuple count.
      o += "        <DataArray type=\"Float64\" Name=\"" + xmlEscape(a.name) + "\" NumberOfComponents=\"" +
           std::to_string(a.components) + "\" NumberOfTuples=\"" +
           std::to_string(a.values.size() / std::max(1, a.components)) + "\" format=\"ascii\">\n";
      putValues(o, a.values, 6, formatDouble);
      o += "        </DataArray>\n";
    }
    o += "    </FieldData>\n";
  }
  o += "    <Piece NumberOfPoints=\"" + std::to_string(nv) + "\" NumberOfVerts=\"0\" NumberOfLines=\"" +
       std::to_string(nl) + "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  o += "      <PointData";
  if (!d.activeScalars.empty()) o += " Scalars=\"" + xmlEscape(d.activeScalars) + "\"";
  if (!d.activeVectors.empty()) o += " Vectors=\"" + xmlEscape(d.activeVectors) + "\"";
  o += ">\n";
  for (const FloatArray& a : d.pointData) putFloatArray(o, a);
  o += "      </PointData>\n";
  o += "      <CellData>\n";
  for (const IntArray& a : d.cellIntData) putIntArray(o, "Int32", a.name, a.values);
  o += "      </CellData>\n";
  o += "      <Points>\n";
  putFloatArray(o, FloatArray{"Points", 3, d.points}, false);
  o += "      </Points>\n";
  o += "      <Lines>\n";
  putIntArray(o, "Int64", "connectivity", connectivity);
  putIntArray(o, "Int64", "offsets", offsets);
  o += "      </Lines>\n";
  o += "    </Piece>\n";
  o += "  </PolyData>\n";
  o += "</VTKFile>\n";
  return o;
}

std::string collectionXml(const std::vector<CollectionEntry>& entries) {
  std::string o;
  o += "<?xml version=\"1.0\"?>\n";
  o += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  o += "  <Collection>\n";
  for (const CollectionEntry& e : entries) {
    o +=
        "    <DataSet timestep=\"" + formatDouble(e.timestep) + "\" group=\"\" part=\"" + std::to_string(e.part) + "\"";
    if (!e.name.empty()) o += " name=\"" + xmlEscape(e.name) + "\"";
    o += " file=\"" + xmlEscape(e.file) + "\"/>\n";
  }
  o += "  </Collection>\n";
  o += "</VTKFile>\n";
  return o;
}

void FileSet::add(const std::string& path, std::string content) {
  paths_.push_back(path);
  contents_.push_back(std::move(content));
}

void FileSet::commit() {
  std::vector<std::string> temps;
  auto removeTemps = [&temps]() {
    for (const std::string& t : temps) std::remove(t.c_str());
  };
  for (std::size_t i = 0; i < paths_.size(); ++i) {
    const std::string tmp = paths_[i] + ".tmp." + std::to_string(::getpid()) + "-" + std::to_string(i);
    temps.push_back(tmp);
    std::ofstream o(tmp, std::ios::binary | std::ios::trunc);
    if (!o) {
      removeTemps();
      throw std::runtime_error(paths_[i] + ": cannot create the output file");
    }
    o.write(contents_[i].data(), static_cast<std::streamsize>(contents_[i].size()));
    o.close();
    if (!o) {
      removeTemps();
      throw std::runtime_error(paths_[i] + ": write failed");
    }
  }
  for (std::size_t i = 0; i < paths_.size(); ++i) {
    if (std::rename(temps[i].c_str(), paths_[i].c_str()) != 0) {
      // Earlier renames already replaced their targets; remove what is left over.
      for (std::size_t j = i; j < temps.size(); ++j) std::remove(temps[j].c_str());
      throw std::runtime_error(paths_[i] + ": cannot move the finished file into place");
    }
  }
}

}  // namespace rodmesh::vtk
