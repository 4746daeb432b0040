#!/usr/bin/env bash
# Installs the packages clm-servo needs from Debian 12: with `main`, only what
# the main job (.ci/main: build clm, commission the simulated motor, plot)
# needs; without, everything to build, test and run.
# Idempotent and non-interactive: packages already present are skipped.
#
#   bash .ci/install-deps.sh        # everything (.ci/run)
#   bash .ci/install-deps.sh main   # the main job's packages
set -euo pipefail

# The main job: the compiler, the libraries clm links, lcm-gen for the
# message headers, and matplotlib for the report's plots.
packages=(
  build-essential cmake pkg-config
  libeigen3-dev libyaml-cpp-dev liblcm-dev liblcm-bin libceres-dev libcli11-dev
  python3 python3-numpy python3-matplotlib
)
case "${1:-all}" in
  main) ;;
  all) packages+=(
  git dpkg-dev help2man man-db
  liblcm-java default-jdk-headless
  catch2 libbenchmark-dev
  can-utils systemd rt-tests
  # the PyTorch reference of the PGNN identification and its CTest test
  # torch_reference_agrees_with_ours_on_cost_and_data_terms; SciPy for the
  # reference's second L-BFGS, --optimiser scipy (docs/benchmarks.md)
  python3-torch python3-scipy python3-yaml
  # HIL suite in a QEMU guest where this kernel has no SocketCAN (docs/hil.md)
  linux-image-amd64 qemu-system-x86 busybox-static iproute2 kmod
  # the systemd tier: the guest's Debian 12 root file system (docs/hil.md)
  debootstrap e2fsprogs
  # libFuzzer harnesses and their runtimes (docs/fuzzing.md)
  clang-14 libclang-rt-14-dev
  ) ;;
  *) echo "usage: install-deps.sh [main]" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
