// Runs a libFuzzer harness without libFuzzer, with any compiler: the short
// fuzz run of the test suite (docs/fuzzing.md). Every seed is run as given,
// then inputs made from the seeds by a mutator with a fixed seed (so that a
// failure reproduces): byte changes, inserted tokens that sit at the edges of
// the allowed ranges, deleted and repeated spans. A finding aborts inside the
// harness (fuzz/fuzz_check.hh) and fails the test.
//
//   fuzz_replay [--mutations N] [--seconds S] [--prefix LINE ...] SEED_FILE ...
//
// With --prefix, every seed file is run once per prefix line, the line and a
// newline before the file's text (fuzz_optimize: a line of flags, then a
// scene). The run stops after N mutated inputs or S seconds, whichever comes
// first; it prints how many inputs it ran.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

void runOne(const std::string& input) {
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
}

std::string mutate(std::string s, std::mt19937_64& rng) {
  static const char* const kTokens[] = {"0",      "-1",     "1e308", "-1e308",  "1e-320", "nan",   "inf",
                                        "1e154",  "1e100",  "2147483647", "1030", "0.002", "\"\"", "null",
                                        "[]",     "{}",     "\"design\"", "\"radius_bounds\"", "\"control_points_per_rod\"",
                                        "\"target\"", "\"weight\"", "\"a\\u0000b\"", "--max-iter", "--tol", "''"};
  static const char kBytes[] = "0123456789-+.eE[]{},:\" \n";
  std::uniform_int_distribution<int> ops(1, 4), kind(0, 4);
  const int n = ops(rng);
  for (int k = 0; k < n; ++k) {
    if (s.empty()) s = "{";
    std::uniform_int_distribution<std::size_t> at(0, s.size() - 1);
    const std::size_t i = at(rng);
    switch (kind(rng)) {
      case 0:
        s[i] = kBytes[std::uniform_int_distribution<std::size_t>(0, sizeof kBytes - 2)(rng)];
        break;
      case 1:
        s.insert(i, kTokens[std::uniform_int_distribution<std::size_t>(0, std::size(kTokens) - 1)(rng)]);
        break;
      case 2: {
        const std::size_t len = std::uniform_int_distribution<std::size_t>(1, 16)(rng);
        s.erase(i, len);
        break;
      }
      case 3: {
        const std::size_t len = std::uniform_int_distribution<std::size_t>(1, 64)(rng);
        s.insert(i, s.substr(i, len));
        break;
      }
      default:
        s[i] = static_cast<char>(std::uniform_int_distribution<int>(0, 255)(rng));
    }
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  long mutations = 2000;
  double seconds = 30.0;
  std::vector<std::string> prefixes, files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mutations" && i + 1 < argc)
      mutations = std::atol(argv[++i]);
    else if (a == "--seconds" && i + 1 < argc)
      seconds = std::atof(argv[++i]);
    else if (a == "--prefix" && i + 1 < argc)
      prefixes.push_back(argv[++i]);
    else
      files.push_back(a);
  }
  std::vector<std::string> seeds;
  for (const std::string& f : files) {
    std::ifstream in(f, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "fuzz_replay: cannot read %s\n", f.c_str());
      return 2;
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (prefixes.empty()) seeds.push_back(text.str());
    for (const std::string& p : prefixes) seeds.push_back(p + "\n" + text.str());
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "usage: fuzz_replay [--mutations N] [--seconds S] [--prefix LINE ...] SEED_FILE ...\n");
    return 2;
  }
  for (const std::string& s : seeds) runOne(s);
  std::mt19937_64 rng(20261126);
  const auto t0 = std::chrono::steady_clock::now();
  long ran = 0;
  for (; ran < mutations; ++ran) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > seconds) break;
    const std::string& seed = seeds[std::uniform_int_distribution<std::size_t>(0, seeds.size() - 1)(rng)];
    runOne(mutate(seed, rng));
  }
  std::printf("fuzz_replay: %zu seeds and %ld mutated inputs, no finding\n", seeds.size(), ran);
  return 0;
}
