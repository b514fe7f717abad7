#!/usr/bin/env bash
# biodyn's main job on a fresh Debian machine: install what is missing, build (Release, all
# cores), then run the main job on the built-in default character. Re-running is incremental.
# The main job (until walking lands): the default character stands quietly for 10 s, then does
# the squat-and-stand sequence, under the velocity-based controllers with the honest foot weld.
# There is no viewer yet, so it is a headless summary (printed, and as JSON in out/).
# Extra arguments go to both `biodyn pose` runs (e.g. ./run.sh --height 1.65 --sex female
# --reaction-time 0.1 --weld off).
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
./scripts/build.sh
mkdir -p out
./build/apps/biodyn model -o out/character.xml --summary out/character.json  # to look at
./build/apps/biodyn pose --scenario stand --duration 10 --json out/stand.json "$@"
./build/apps/biodyn pose --scenario squat --json out/squat.json --csv out/squat.csv "$@"
