#!/usr/bin/env bash
# Installs every package clm-servo needs to build, test and run, from Debian 12.
# Idempotent and non-interactive: packages already present are skipped.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git dpkg-dev
  libeigen3-dev libyaml-cpp-dev
  liblcm-dev liblcm-bin liblcm-java default-jdk-headless
  catch2 libceres-dev libcli11-dev libbenchmark-dev
  can-utils systemd rt-tests
  python3 python3-numpy python3-matplotlib
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
)

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
