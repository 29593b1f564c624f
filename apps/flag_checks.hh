// Checks of numeric flag values shared by the mesh and export verbs: an
// absurd value is a usage error (exit 2) whose one-line message names the
// flag, the text as typed and the allowed range.
#pragma once

#include "io/scene_reader.hh"

#include <CLI/CLI.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

namespace rodmesh::cli {

// A value as the user typed it: main() passes "-inf" and "-nan" on with a
// leading space so that CLI11 takes them for values, not flags.
inline std::string asTyped(const std::string& text) {
  return !text.empty() && text[0] == ' ' ? text.substr(1) : text;
}

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
        throw InputError(f.flag + ": '" + asTyped(raw) + "' is not a finite number (allowed: " + f.allowed + ")");
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
// What is wrong with `text` as a whole number in [lo, hi] (also an empty
// text, which CLI11 would read as 0), or "" when nothing is. The Python
// bindings check their keyword options with it too, for the same message.
inline std::string wholeNumberProblem(const std::string& text, long long lo, long long hi) {
  if (wholeNumberWithin(text, lo, hi)) return "";
  return "must be a whole number in the allowed range [" + std::to_string(lo) + ", " + std::to_string(hi) +
         "] (got '" + text + "')";
}

inline CLI::Validator wholeNumberIn(long long lo, long long hi) {
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator([lo, hi](std::string& text) -> std::string { return wholeNumberProblem(text, lo, hi); },
                        "INT in " + range);
}

// The allowed range of a real-valued flag: [lo, hi], either end open.
struct RealRange {
  double lo = 0.0, hi = 0.0;
  bool loOpen = false, hiOpen = false;
  std::string unit;  // "s", "m", ... (empty: none)

  bool contains(double v) const { return (loOpen ? v > lo : v >= lo) && (hiOpen ? v < hi : v <= hi); }
  // "(0, 1e+09] s"; an upper end of DBL_MAX reads "inf)" (any finite number).
  std::string text() const {
    char buf[96];
    if (hi >= std::numeric_limits<double>::max())
      std::snprintf(buf, sizeof buf, "%s%g, inf)", loOpen ? "(" : "[", lo);
    else
      std::snprintf(buf, sizeof buf, "%s%g, %g%s", loOpen ? "(" : "[", lo, hi, hiOpen ? ")" : "]");
    return std::string(buf) + (unit.empty() ? "" : " " + unit);
  }
};

// True when `text` is a whole real number (strtod reads all of it, nothing
// before or after) within `range`; NaN and infinities are in no range.
inline bool realNumberWithin(const std::string& text, const RealRange& range) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return false;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return false;
  return std::isfinite(v) && range.contains(v);
}

// CLI11 validator for real-valued flags, run on the text before CLI11
// converts it: a number in `range`, else the message (CLI11 prefixes the
// flag) gives the range and the text as typed ("--time-limit: must be a
// number in [0, 1e+09] s (got '-1e-9')"), never a reformatted value, and
// CLI11 never gets to say "Could not convert". An empty text is refused too
// (CLI11 would read it as 0).
inline std::string realNumberProblem(const std::string& text, const RealRange& range) {
  if (realNumberWithin(text, range)) return "";
  return "must be a number in the allowed range " + range.text() + " (got '" + asTyped(text) + "')";
}

inline CLI::Validator realNumberIn(const RealRange& range) {
  return CLI::Validator([range](std::string& text) -> std::string { return realNumberProblem(text, range); },
                        "NUMBER in " + range.text());
}

// Ranges of the solver flags of simulate and optimize (docs/formats.md,
// "Command line"). A wall-clock second count beyond 1e9 (31 years) is a typo.
inline const RealRange kTimeLimitRange{0.0, 1e9, false, false, "s (0: none)"};
inline const RealRange kHeartbeatRange{0.0, 1e9, false, false, "s (0: never)"};
inline const RealRange kPositiveSecondsRange{0.0, 1e9, true, false, "s"};
// --duration: any finite positive time; the frame count (duration x fps,
// at most 1e6) bounds it.
inline const RealRange kDurationRange{0.0, std::numeric_limits<double>::max(), true, false, "s"};
inline const RealRange kSecondsRange{0.0, 1e9, false, false, "s"};
inline const RealRange kFpsRange{0.0, 1e6, true, false, "frames per second"};
inline const RealRange kOptimizeTolRange{0.0, 1.0, true, true, ""};
inline const RealRange kSimulateTolRange{1e-16, 0.1, false, false, ""};
// simulate --max-iter: at most this many (relaxation counts force
// evaluations; Newton's own bounds are checked by simulate's option check).
constexpr long long kMaxSimulateIterations = 100000000;
constexpr long long kMaxOptimizeIterations = 1000000;
constexpr long long kMaxThreads = 256;

}  // namespace rodmesh::cli
