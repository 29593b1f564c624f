// Reads and validates a "rodmesh-scene/1" JSON file (../shared/contracts.md §1).
#pragma once

#include "model/scene.hh"

#include <stdexcept>
#include <string>

namespace rodmesh {

// Bad user input. The message names the file, the key path and the offending
// index or value; the CLI prints it and exits with status 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses `text` as the scene stored in `path` (path is used in messages only).
// Throws InputError on any violation of the contract.
Scene parseScene(const std::string& text, const std::string& path);

// Reads the file, then parseScene. Throws InputError if it cannot be read.
Scene readSceneFile(const std::string& path);

// Warnings collected while parsing (unknown keys and the like); printed by the CLI.
const std::vector<std::string>& lastSceneWarnings();

}  // namespace rodmesh
