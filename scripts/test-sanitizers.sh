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
# Test names (GoogleTest suites) of the subset, and the test sources that
# define them: the subset's build compiles only these (RODMESH_TEST_SOURCES,
# tests/CMakeLists.txt), and every suite named must match a test of that
# build (checked below). Not SandIpopt (Ipopt's own derivative checker, a
# second party's check of the TNLP's wiring: one optimizer run plus forward
# differences of every entry, the slowest test under the sanitizers and the
# last to end): SandDerivatives runs the same evaluations of the TNLP under
# them, and --all runs it too.
suites=(
  SceneReader SceneReaderErrors OptimizeValidation SurfaceRead 'SurfaceReader[A-Za-z]*'   # readers
  Archive ArchiveInterrupt ArchiveInterruptDeathTest ArchiveBuilderTest BadArchiveCli      # archive
  FuzzRegressions FuzzReplay                                                                # fuzz inputs
  CliTest MeshInputCli RobustCli                                                            # bad input
  TaylorHelper '[A-Za-z]*/?TermDerivatives' JointKernels ConnectionInvariance               # derivatives
  '[A-Za-z]*/?HardConnection' '[A-Za-z]*/?SandDerivatives' '[A-Za-z]*/?ReducedGradient' DesignSpace
)
sources=(
  io/scene_reader_test.cc meshing/surface_test.cc meshing/surface_reader_test.cc
  io/archive_test.cc cli/archive_builder_test.cc cli/bad_archive_cli_test.cc
  io/fuzz_regression_test.cc meshing/surface_fuzz_regression_test.cc
  cli/cli_test.cc cli/mesh_input_cli_test.cc cli/robust_cli_test.cc
  model/derivatives_test.cc model/joint_kernel_test.cc model/joint_connection_kernel_test.cc
  model/connection_derivatives_test.cc nlp/sand_derivatives_test.cc
  solver/reduced_gradient_test.cc model/design_space_test.cc
)
subset="^($(IFS='|'; echo "${suites[*]}"))\\."

# -O1 everywhere: instrumented code at -O2 took 1.7 times as long to compile
# (model/effects.cc: 36 s against 21 s), and the kernels are at -O1 anyway.
# -g1: line tables, so that reports name file and line. No -DNDEBUG:
# assertions on. No -march=native: fewer Eigen code paths to compile, and GCC
# 12 warns falsely inside its AVX-512 intrinsics under the sanitizers.
if [ "$all" = 1 ]; then test_sources=""; else test_sources="$(IFS=';'; echo "${sources[*]}")"; fi
cmake -S . -B "$build" -DRODMESH_SANITIZE=ON -DRODMESH_NATIVE=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" \
  -DRODMESH_TEST_SOURCES="$test_sources" >/dev/null

# The executables the subset runs (no benchmarks, no hard-case suite).
subset_targets=(rodmesh_tests rodmesh rodmesh_cli_tests fuzz_optimize_replay)
# (The list is read first: grep -q would end the pipe early, and pipefail
# would then count the target as missing.)
targets_help="$(cmake --build "$build" --target help)"
for t in meshing_tests rodmesh_nlp_tests; do
  if grep -q "^\.\.\. $t\$" <<<"$targets_help"; then subset_targets+=("$t"); fi
done

if [ "$all" = 1 ]; then
  cmake --build "$build" -j"$jobs"
else
  cmake --build "$build" -j"$jobs" --target "${subset_targets[@]}"
fi

# Every suite of the list must name tests of this build: a suite whose
# source is missing from the list above would otherwise drop out unseen.
if [ "$all" = 0 ]; then
  for suite in "${suites[@]}"; do
    listed="$(ctest --test-dir "$build" -N -R "^(${suite})\\.")"
    if ! grep -q '^Total Tests: [1-9]' <<<"$listed"; then
      echo "test-sanitizers: no test of suite '$suite' in $build (is its source in the list?)" >&2
      exit 1
    fi
  done
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
