#!/usr/bin/env bash
# Same set-up as run.sh, then the whole test suite with ctest.
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
./scripts/build.sh
cd build
ctest --output-on-failure -j "$(nproc)"
