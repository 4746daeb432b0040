#!/bin/sh
# Packages the benchmarks need beyond .ci/install-deps.sh (CI does not run
# them): python3-torch for the PyTorch reference of the PGNN identification
# (tools/reference, docs/benchmarks.md) and the slow CTest test
# torch_reference_agrees_with_ours_on_cost_and_data_terms. Debian packages
# only (PyTorch 1.13 from Debian 12); run as root.
set -eu
apt-get install -y --no-install-recommends python3-torch python3-yaml python3-numpy
