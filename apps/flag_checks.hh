// Checks of numeric flag values shared by the mesh and export verbs.
#pragma once

#include "io/scene_reader.hh"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace rodmesh::cli {

// CLI11 reads "1e999" as inf (through long double) and accepts "inf" and
// "nan": every value given to these flags must be a finite number. Throws
// InputError naming the flag and the text as typed. Text that is not a number
// at all is left to CLI11 or to the flag's own parser (e.g. a side name).
inline void requireFiniteNumbers(CLI::App& app, const std::vector<std::string>& flags) {
  for (const std::string& f : flags) {
    const CLI::Option* opt = app.get_option_no_throw(f);
    if (opt == nullptr || opt->count() == 0) continue;
    for (const std::string& raw : opt->results()) {
      char* end = nullptr;
      const double v = std::strtod(raw.c_str(), &end);
      if (end == raw.c_str() || *end != '\0') continue;
      if (!std::isfinite(v)) throw InputError(f + ": '" + raw + "' is not a finite number");
    }
  }
}

}  // namespace rodmesh::cli
