#!/usr/bin/env bash
# biodyn's main job on a fresh Debian machine: install what is missing, build (Release, all
# cores), then run the main job on the built-in default character. Re-running is incremental.
# The main job: the default character walks 20 s from standing under the torque walker with the
# honest foot weld. There is no viewer yet (issue 6), so it is a headless summary (printed, and
# as JSON and a per-step CSV trace in out/).
# Extra arguments go to `biodyn walk` (e.g. ./run.sh --weld off --reaction-time 0.1
# --height 1.95 --mass 120 --duration 60).
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
./scripts/build.sh
mkdir -p out
./build/apps/biodyn model -o out/character.xml --summary out/character.json  # to look at
./build/apps/biodyn walk --duration 20 --json out/walk.json --csv out/walk.csv "$@"
