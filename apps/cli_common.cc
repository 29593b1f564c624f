#include "apps/cli_common.hh"

#include <cstdio>
#include <iostream>
#include <sstream>
#include <unistd.h>

namespace rodmesh::cli {

void checkOutputPath(const std::string& path, const std::string& flag) {
  if (path.empty()) throw InputError(flag + ": output path is empty");
  std::string dir = ".";
  auto slash = path.find_last_of('/');
  if (slash != std::string::npos) dir = slash == 0 ? "/" : path.substr(0, slash);
  if (access(dir.c_str(), W_OK) != 0) throw InputError(flag + " " + path + ": directory " + dir + " does not exist or is not writable");
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

std::string formatSeconds(double s) {
  char buf[32];
  if (s < 1.0) std::snprintf(buf, sizeof buf, "%.1f ms", s * 1e3);
  else std::snprintf(buf, sizeof buf, "%.2f s", s);
  return buf;
}

}  // namespace rodmesh::cli
