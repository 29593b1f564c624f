#!/usr/bin/env bash
# Builds rodmesh with AddressSanitizer and UndefinedBehaviorSanitizer into its
# own folder, build-asan/ (cmake -DRODMESH_SANITIZE=ON, cmake/sanitize.cmake;
# -O1, assertions on), and runs tests under them. Any report fails the test
# that caused it.
#
#   scripts/test-sanitizers.sh         the subset that CI runs: the readers of
#                                      scenes and surfaces, the archive reader
#                                      and writer, the fuzz regression inputs
#                                      (fuzz/regressions/), the command line's
#                                      answers to bad input, and the derivative
#                                      (Taylor) tests
#   scripts/test-sanitizers.sh --all   the whole suite (hard and slow cases
#                                      included)
#
# Figures and what the options mean: docs/testing.md.
set -euo pipefail
cd "$(dirname "$0")/.."

all=0
case "${1:-}" in
  '') ;;
  --all) all=1 ;;
  *) echo "usage: scripts/test-sanitizers.sh [--all]" >&2; exit 2 ;;
esac

./scripts/install-deps.sh
build=build-asan
jobs="$(nproc 2>/dev/null || echo 2)"
# -O1 everywhere: instrumented code at -O2 took 1.7 times as long to compile
# (model/effects.cc: 36 s against 21 s), and the kernels are at -O1 anyway.
# -g1: line tables, so that reports name file and line. No -DNDEBUG:
# assertions on. No -march=native: fewer Eigen code paths to compile, and GCC
# 12 warns falsely inside its AVX-512 intrinsics under the sanitizers.
cmake -S . -B "$build" -DRODMESH_SANITIZE=ON -DRODMESH_NATIVE=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" >/dev/null

# The executables the subset runs (no benchmarks, no hard-case suite).
subset_targets=(rodmesh_tests rodmesh rodmesh_cli_tests fuzz_optimize_replay)
# (The list is read first: grep -q would end the pipe early, and pipefail
# would then count the target as missing.)
targets_help="$(cmake --build "$build" --target help)"
for t in meshing_tests rodmesh_nlp_tests; do
  if grep -q "^\.\.\. $t\$" <<<"$targets_help"; then subset_targets+=("$t"); fi
done
# Test names (GoogleTest suites) of the subset. Not SandIpopt (Ipopt's own
# derivative checker, a second party's check of the TNLP's wiring: one
# optimizer run plus forward differences of every entry, the slowest test
# under the sanitizers and the last to end): SandDerivatives runs the same
# evaluations of the TNLP under them, and --all runs it too.
subset='^('
subset+='SceneReader|SceneReaderErrors|OptimizeValidation|SurfaceRead|SurfaceReader[A-Za-z]*'  # readers
subset+='|Archive|ArchiveInterrupt|ArchiveInterruptDeathTest|ArchiveBuilderTest|BadArchiveCli'  # archive
subset+='|FuzzRegressions|FuzzReplay'                                                              # fuzz inputs
subset+='|CliTest|MeshInputCli|RobustCli'                                                          # bad input
subset+='|TaylorHelper|[A-Za-z]*/?TermDerivatives|JointKernels|ConnectionInvariance'              # derivatives
subset+='|[A-Za-z]*/?HardConnection|[A-Za-z]*/?SandDerivatives|[A-Za-z]*/?ReducedGradient|DesignSpace'
subset+=')\.'

if [ "$all" = 1 ]; then
  cmake --build "$build" -j"$jobs"
else
  cmake --build "$build" -j"$jobs" --target "${subset_targets[@]}"
fi

# halt_on_error: the first report ends the process (a failed test).
# allocator_may_return_null: an allocation too large for the sanitizer's
# allocator fails as it would without the sanitizers (std::bad_alloc; the
# archive reader must answer corrupted sizes with a message).
# LeakSanitizer runs at exit; scripts/lsan-suppressions.txt is for leaks
# inside the HDF5 library itself (docs/fuzzing.md, "The HDF5 library"); none
# so far.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_leaks=1:allocator_may_return_null=1:check_initialization_order=1:strict_init_order=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan-suppressions.txt:print_suppressions=0"

start=$(date +%s)
if [ "$all" = 1 ]; then
  ctest --test-dir "$build" --output-on-failure -j"$jobs"
else
  ctest --test-dir "$build" --output-on-failure -j"$jobs" -R "$subset"
fi
echo "test-sanitizers: tests ran in $(($(date +%s) - start)) s"
