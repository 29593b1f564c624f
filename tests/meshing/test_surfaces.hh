// Small analytic surfaces for the meshing tests.
#pragma once

#include "meshing/surface.hh"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <unistd.h>
#include <vector>

namespace rodmesh::meshing::testing {

// Icosphere of radius r with `levels` subdivisions.
inline TriSurface icosphere(double r, int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  TriSurface s;
  s.sourcePath = "icosphere";
  s.vertices = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : s.vertices) v.normalize();
  s.faces = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
             {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto m = [&](int a, int b) {
      auto k = std::minmax(a, b);
      auto it = mid.find(k);
      if (it != mid.end()) return it->second;
      s.vertices.push_back((s.vertices[a] + s.vertices[b]).normalized());
      return mid[k] = static_cast<int>(s.vertices.size()) - 1;
    };
    std::vector<Tri> f;
    for (const Tri& t3 : s.faces) {
      const int ab = m(t3[0], t3[1]), bc = m(t3[1], t3[2]), ca = m(t3[2], t3[0]);
      f.push_back({t3[0], ab, ca});
      f.push_back({t3[1], bc, ab});
      f.push_back({t3[2], ca, bc});
      f.push_back({ab, bc, ca});
    }
    s.faces = f;
  }
  for (auto& v : s.vertices) v *= r;
  return s;
}

// Upper half (z >= 0) of a sphere of radius r: an open dome, from a polar grid.
inline TriSurface dome(double r, int rings, int sectors) {
  TriSurface s;
  s.sourcePath = "dome";
  s.vertices.push_back({0, 0, r});
  for (int i = 1; i <= rings; ++i) {
    const double phi = 0.5 * M_PI * i / rings;
    for (int j = 0; j < sectors; ++j) {
      const double th = 2 * M_PI * j / sectors;
      s.vertices.push_back({r * std::sin(phi) * std::cos(th), r * std::sin(phi) * std::sin(th), r * std::cos(phi)});
    }
  }
  for (int j = 0; j < sectors; ++j) s.faces.push_back({0, 1 + j, 1 + (j + 1) % sectors});
  for (int i = 0; i + 1 < rings; ++i) {
    const int a = 1 + i * sectors, b = 1 + (i + 1) * sectors;
    for (int j = 0; j < sectors; ++j) {
      const int j1 = (j + 1) % sectors;
      s.faces.push_back({a + j, b + j, b + j1});
      s.faces.push_back({a + j, b + j1, a + j1});
    }
  }
  return s;
}

// Every path tempPath handed out, removed when the test process exits
// (whether or not a test created the file, or removed it itself).
struct TempPaths {
  std::vector<std::string> paths;
  ~TempPaths() {
    for (const std::string& p : paths) std::remove(p.c_str());
  }
};
inline TempPaths& tempPaths() {
  static TempPaths t;
  return t;
}

// A unique temporary path with the given suffix (file not created; removed
// at the process's exit).
inline std::string tempPath(const std::string& suffix) {
  static int counter = 0;
  std::string p = "/tmp/rodmesh_meshing_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + suffix;
  tempPaths().paths.push_back(p);
  return p;
}

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream o(path, std::ios::binary);
  o << text;
}

inline std::string objText(const TriSurface& s) {
  std::string t;
  char buf[128];
  for (const Vec3& v : s.vertices) {
    std::snprintf(buf, sizeof buf, "v %.17g %.17g %.17g\n", v.x(), v.y(), v.z());
    t += buf;
  }
  for (const Tri& f : s.faces) t += "f " + std::to_string(f[0] + 1) + " " + std::to_string(f[1] + 1) + " " + std::to_string(f[2] + 1) + "\n";
  return t;
}

// Distance from p to the surface (brute force).
inline double distanceToSurface(const TriSurface& s, const Vec3& p) {
  double d = 0;
  closestPoint(s, p, {}, &d);
  return d;
}

}  // namespace rodmesh::meshing::testing
