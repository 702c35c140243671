#!/usr/bin/env bash
# Installs, from Debian packages only, everything needed to build and test the project.
# Idempotent: packages already present are skipped by apt-get; running it twice changes nothing.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  ccache                 # the sanitizer build reuses the Release build's numerical objects (PD_CCACHE)
  libeigen3-dev          # dense/sparse linear algebra, fixed-size per-element types
  libsuitesparse-dev     # CHOLMOD supernodal Cholesky
  libopenblas-dev        # BLAS behind CHOLMOD (about 3x the reference BLAS on large cloth)
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev  # CGAL: decimation, independent intersection checks
  libzmq3-dev cppzmq-dev # scheduler <-> worker messaging
  libsqlite3-dev         # task store
  nlohmann-json3-dev     # scene files, messages
  libhdf5-dev            # frame store
  libgtest-dev           # tests
  libcli11-dev           # the pd command line
  libtbb-dev             # oneTBB: element loops on every core (common/util/parallel.h)
  iproute2               # ip netns + veth: the CURVE test on a non-loopback address (tests/integration/)
  slurm-wlm munge        # Slurm workers (deploy/slurm/): the test starts slurmctld + slurmd + munged on localhost
  systemd                # systemd-analyze verify of deploy/systemd/'s units (tests/deploy/)
  python3-matplotlib python3-h5py  # the speed-against-error report's plots (bench/report/), run with /usr/bin/python3
  clang libclang-rt-14-dev  # libFuzzer targets (fuzz/, -DPD_BUILD_FUZZERS=ON, docs/fuzzing.md)
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
echo "setup: installing ${missing[*]}"
# Daemons packaged with a service (slurmctld, slurmd, munge) must not start during the install: the
# tests start their own, with their own configuration. policy-rc.d exit 101 = "action forbidden";
# one already present (as in many container images) is left as it is.
policy=/usr/sbin/policy-rc.d
if [ ! -e "$policy" ]; then
  printf '#!/bin/sh\nexit 101\n' | $SUDO tee "$policy" >/dev/null && $SUDO chmod 755 "$policy"
  trap '$SUDO rm -f "$policy"' EXIT  # also when the install fails
fi
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
