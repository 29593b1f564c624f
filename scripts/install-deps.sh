#!/usr/bin/env bash
# Installs rodmesh's build and test dependencies from Debian 12 packages.
# Idempotent: packages already present are not fetched again, and the package
# index is refreshed only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libeigen3-dev coinor-libipopt-dev libcgal-dev libhdf5-dev
  nlohmann-json3-dev libcli11-dev libgtest-dev libsuitesparse-dev
  python3-numpy python3-h5py hdf5-tools
  # the Python package (python/, tests/python)
  pybind11-dev python3-dev python3-scipy python3-pytest
  # scripts/render.py; tests/cli/vtk_check.py reads .vtp files with VTK's own reader
  python3-matplotlib python3-vtk9
  # Optimised BLAS for MUMPS's dense frontal factorizations inside Ipopt
  # (replaces the reference BLAS through Debian's alternatives; serial, so
  # timings do not depend on BLAS threads). SAND's KKT factorizations spent
  # 63% of their time in the reference dgemm.
  libopenblas0-serial
  # scripts/fuzz.sh: clang 14; libFuzzer and the sanitizer runtimes are in
  # libclang-rt-14-dev, only recommended by clang
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
