// Helpers shared by the command implementations.
#pragma once

#include "io/archive.hh"
#include "io/scene_reader.hh"
#include "model/effects.hh"
#include "model/network.hh"

#include <string>

namespace rodmesh::cli {

// Throws InputError unless the directory of `path` exists and is writable.
void checkOutputPath(const std::string& path, const std::string& flag);

// Fills the /model part of an archive.
void describeModel(Archive& a, const RodNetwork& net, const EffectSet& fx, long long dofsPerPose);

// Prints the scene warnings and the effects summary to stderr.
void printEffects(const EffectSet& fx, const RodNetwork& net, long long dofsPerPose);

// Formats seconds as "12.3 ms" / "1.23 s".
std::string formatSeconds(double s);

}  // namespace rodmesh::cli
