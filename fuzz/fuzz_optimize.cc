// libFuzzer harness (issue 23): the checks `rodmesh optimize` makes before
// any work, on arbitrary input. The first line holds optimize flags
// (`--max-iter`, `--time-limit`, `--tol`, `--threads` with values, as a shell
// would split them on spaces), the rest is a scene (with a design block).
//
// Flags go through the same CLI11 validators as apps/cmd_optimize.cc
// (apps/flag_checks.hh): a rejection is one line naming the flag, never
// CLI11's "Could not convert"; an accepted value lies in its range. The scene
// goes through parseScene and validateForOptimize (rejections: one line
// naming the file); an accepted one builds its DesignSpace, whose initial
// design and designs from controls anywhere within the bounds (taken from the
// input's bytes) have finite rest positions and vertex radii within the radius
// bounds to the last digit.
#include "apps/flag_checks.hh"
#include "fuzz/fuzz_check.hh"
#include "io/scene_reader.hh"
#include "model/design_space.hh"
#include "model/effects.hh"
#include "model/network.hh"

#include <CLI/CLI.hpp>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace rodmesh;

namespace {

void checkFlags(const std::string& line) {
  CLI::App app{"fuzz"};
  int maxIter = 2000, threads = 1;
  double timeLimit = 0.0, tol = 1e-6;
  app.add_option("--max-iter", maxIter)->check(cli::wholeNumberIn(0, cli::kMaxOptimizeIterations));
  app.add_option("--time-limit", timeLimit)->check(cli::realNumberIn(cli::kTimeLimitRange));
  app.add_option("--tol", tol)->check(cli::realNumberIn(cli::kOptimizeTolRange));
  app.add_option("--threads", threads)->check(cli::wholeNumberIn(1, cli::kMaxThreads));
  app.allow_extras();
  std::vector<std::string> args;
  std::istringstream in(line);
  for (std::string t; in >> t;) args.push_back(t);
  if (args.size() > 16) return;
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    const std::string m = e.what();
    fuzz::require(m.find('\n') == std::string::npos, "a flag message spreads over lines");
    fuzz::require(m.find("Could not convert") == std::string::npos, "CLI11's 'Could not convert' reached the user");
    return;
  }
  fuzz::require(maxIter >= 0 && maxIter <= cli::kMaxOptimizeIterations, "--max-iter accepted out of range");
  fuzz::require(threads >= 1 && threads <= cli::kMaxThreads, "--threads accepted out of range");
  fuzz::require(cli::kTimeLimitRange.contains(timeLimit), "--time-limit accepted out of range");
  fuzz::require(cli::kOptimizeTolRange.contains(tol), "--tol accepted out of range");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t eol = input.find('\n');
  checkFlags(input.substr(0, eol));
  if (eol == std::string::npos) return 0;
  const std::string text = input.substr(eol + 1);
  const std::string file = "fuzz.json";
  Scene s;
  try {
    s = parseScene(text, file);
    validateForOptimize(s);
  } catch (const InputError& e) {
    fuzz::checkMessage(e.what(), file);
    return 0;
  }
  const RodNetwork net(s);
  const EffectSet fx = resolveEffects(s, net);
  DesignSpace space(s, fx);
  const double lo = space.radiusLower(), hi = space.radiusUpper();
  fuzz::require(lo > 0 && lo <= hi, "empty or non-positive radius bounds");
  ControlValues c = space.initialControls(s);
  auto checkDesign = [&](const ControlValues& controls) {
    const Design d = space.toDesign(controls);
    for (const Vec2& r : d.radii)
      fuzz::require(r[0] >= lo && r[0] <= hi && r[1] >= lo && r[1] <= hi, "a vertex radius leaves the bounds");
    for (const Vec3& x : d.restPositions) fuzz::require(x.allFinite(), "a rest position is not finite");
  };
  checkDesign(c);
  // Controls anywhere within the bounds, from the input's bytes: on the
  // bounds themselves (the designs optimizers end at) and between them.
  for (Eigen::Index i = 0; i < c.radii.size(); ++i) {
    const unsigned char b = static_cast<unsigned char>(text[static_cast<std::size_t>(i) % text.size()]);
    c.radii.data()[i] = b % 3 == 0 ? lo : b % 3 == 1 ? hi : lo + (hi - lo) * (b / 255.0);
  }
  checkDesign(c);
  return 0;
}
