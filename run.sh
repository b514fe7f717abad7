#!/usr/bin/env bash
# biodyn's main job on a fresh Debian machine: install what is missing, build (Release, all
# cores), then run the main job on the built-in default character. Re-running is incremental.
# Extra arguments go to `biodyn drop` (e.g. ./run.sh --height 1.65 --sex female).
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
./scripts/build.sh
mkdir -p out
./build/apps/biodyn drop -o out/character.xml --json out/drop.json "$@"
