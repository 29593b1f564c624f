// Reads and validates a "rodmesh-scene/1" JSON file (docs/formats.md §1).
#pragma once

#include "model/scene.hh"

#include <cstddef>
#include <stdexcept>
#include <string>

namespace rodmesh {

// Bad user input. The message names the file, the key path and the offending
// index or value; the CLI prints it and exits with status 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Text from an input file as shown in a message or a report: control
// characters (newlines, terminal escapes) as \xNN, so that a message stays one
// line; at most `limit` bytes, then "...".
std::string printableText(const std::string& text, std::size_t limit = std::string::npos);

// Parses `text` as the scene stored in `path` (path is used in messages only).
// Throws InputError on any violation of the contract, including a value
// outside its plausible range (model/limits.hh; docs/formats.md) and a pose
// name that cannot name an HDF5 group (empty, '/', "." or "..", control
// characters, over 255 bytes).
Scene parseScene(const std::string& text, const std::string& path);

// Reads the file, then parseScene. Throws InputError if it cannot be read.
Scene readSceneFile(const std::string& path);

// Input files (scenes, surfaces) larger than this are refused: a scene of a
// million vertices takes about 60 MB.
constexpr std::size_t kMaxInputFileBytes = std::size_t(256) << 20;

// The whole file `path` as bytes. Throws InputError naming the file and `what`
// ("scene file") if it is missing, not a regular file (a directory, device,
// FIFO or socket: checked by stat() without opening it, so that a FIFO
// without a writer cannot block), unreadable, or larger than
// kMaxInputFileBytes (by its size, before reading).
std::string readInputFile(const std::string& path, const std::string& what);

// The checks `rodmesh optimize` needs beyond parseScene (contract §4, "Bad
// input for optimize"): a `design` block with at least one parameter; a target
// for every pose; radius bounds > 0; every initial radius within
// `radius_bounds` (when given; without them the optimizer derives its own);
// `control_points_per_rod` in [2, limits::kMaxControlPoints]; weights >= 0,
// not all zero; bounds, radii and targets within their plausible ranges. Throws InputError
// with a message "FILE: key.path: what, got VALUE" naming the key the user wrote
// (`radius` or `radii`, found in Scene::sourceText). Scenes built in code are
// checked too (their messages use the same key paths).
void validateForOptimize(const Scene& scene);

// Warnings collected while parsing (unknown keys and the like); printed by the CLI.
const std::vector<std::string>& lastSceneWarnings();

}  // namespace rodmesh
