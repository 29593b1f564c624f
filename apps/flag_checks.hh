// Checks of numeric flag values shared by the mesh and export verbs: an
// absurd value is a usage error (exit 2) whose one-line message names the
// flag, the text as typed and the allowed range.
#pragma once

#include "io/scene_reader.hh"

#include <CLI/CLI.hpp>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace rodmesh::cli {

// A flag taking real numbers and what it allows, for messages ("[1e-06, 1e+06]").
struct RealFlag {
  std::string flag;
  std::string allowed;
};

// CLI11 reads "1e999" as inf (through long double) and accepts "inf" and
// "nan": every value given to these flags must be a finite number. Throws
// InputError naming the flag, the text as typed and the allowed range. Text
// that is not a number at all is left to CLI11 or to the flag's own parser
// (e.g. a side name).
inline void requireFiniteNumbers(CLI::App& app, const std::vector<RealFlag>& flags) {
  for (const RealFlag& f : flags) {
    const CLI::Option* opt = app.get_option_no_throw(f.flag);
    if (opt == nullptr || opt->count() == 0) continue;
    for (const std::string& raw : opt->results()) {
      char* end = nullptr;
      const double v = std::strtod(raw.c_str(), &end);
      if (end == raw.c_str() || *end != '\0') continue;
      if (!std::isfinite(v))
        throw InputError(f.flag + ": '" + raw + "' is not a finite number (allowed: " + f.allowed + ")");
    }
  }
}

// True when `text` is a whole decimal number (optional sign, digits only) in [lo, hi].
inline bool wholeNumberWithin(const std::string& text, long long lo, long long hi) {
  std::size_t i = text.size() > 0 && (text[0] == '-' || text[0] == '+') ? 1 : 0;
  if (i == text.size() || text.size() > 19) return false;
  for (std::size_t k = i; k < text.size(); ++k)
    if (text[k] < '0' || text[k] > '9') return false;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), nullptr, 10);
  return errno == 0 && v >= lo && v <= hi;
}

// CLI11 validator for integer flags, run on the text before CLI11 converts
// it (so that "2147483648" or "1e3" is reported with the range instead of
// "Could not convert"): a whole number in [lo, hi].
inline CLI::Validator wholeNumberIn(long long lo, long long hi) {
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        if (wholeNumberWithin(text, lo, hi)) return "";
        return "must be a whole number in " + range + " (got '" + text + "')";
      },
      "INT in " + range);
}

}  // namespace rodmesh::cli
