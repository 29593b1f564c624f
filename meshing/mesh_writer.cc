// Triangle mesh writers (STL binary, OBJ, PLY binary), atomic.
#include "io/scene_reader.hh"
#include "meshing/solid.hh"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>
#include <unistd.h>

namespace rodmesh::meshing {
namespace {

std::string extensionOf(const std::string& path) {
  auto dot = path.find_last_of('.');
  auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  for (char& ch : e) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return e;
}

template <class T>
void put(std::ofstream& o, T v) {
  o.write(reinterpret_cast<const char*>(&v), sizeof(T));  // x86-64: little endian
}

void writeStl(std::ofstream& o, const IndexedMesh& m) {
  char header[80];
  std::memset(header, 0, sizeof header);
  std::snprintf(header, sizeof header, "rodmesh export (binary STL, metres)");
  o.write(header, 80);
  put<std::uint32_t>(o, static_cast<std::uint32_t>(m.faces.size()));
  for (const Tri& t : m.faces) {
    const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    Vec3 n = (b - a).cross(c - a);
    if (n.norm() > 0) n.normalize();
    for (int i = 0; i < 3; ++i) put<float>(o, static_cast<float>(n[i]));
    for (const Vec3* p : {&a, &b, &c})
      for (int i = 0; i < 3; ++i) put<float>(o, static_cast<float>((*p)[i]));
    put<std::uint16_t>(o, 0);
  }
}

void writeObj(std::ofstream& o, const IndexedMesh& m) {
  o << "# rodmesh export (metres)\n";
  char buf[128];
  for (const Vec3& v : m.vertices) {
    std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", v.x(), v.y(), v.z());
    o << buf;
  }
  for (const Tri& t : m.faces) o << "f " << t[0] + 1 << " " << t[1] + 1 << " " << t[2] + 1 << "\n";
}

void writePly(std::ofstream& o, const IndexedMesh& m) {
  o << "ply\nformat binary_little_endian 1.0\ncomment rodmesh export (metres)\n";
  o << "element vertex " << m.vertices.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  o << "element face " << m.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const Vec3& v : m.vertices)
    for (int i = 0; i < 3; ++i) put<float>(o, static_cast<float>(v[i]));
  for (const Tri& t : m.faces) {
    put<std::uint8_t>(o, 3);
    for (int i = 0; i < 3; ++i) put<std::int32_t>(o, t[i]);
  }
}

}  // namespace

void checkMeshExtension(const std::string& path) {
  const std::string e = extensionOf(path);
  if (e != "stl" && e != "obj" && e != "ply")
    throw InputError(path + ": unsupported output format '." + e + "' (expected .stl, .obj or .ply)");
}

void writeMeshFile(const IndexedMesh& m, const std::string& path) {
  checkMeshExtension(path);
  const std::string e = extensionOf(path);
  std::random_device rd;
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(rd() % 1000000);
  {
    std::ofstream o(tmp, std::ios::binary | std::ios::trunc);
    if (!o) throw std::runtime_error(path + ": cannot create output file (" + tmp + ")");
    if (e == "stl") writeStl(o, m);
    else if (e == "obj") writeObj(o, m);
    else writePly(o, m);
    o.flush();
    if (!o) {
      o.close();
      std::remove(tmp.c_str());
      throw std::runtime_error(path + ": write failed");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot move the finished file into place");
  }
}

}  // namespace rodmesh::meshing
