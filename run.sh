#!/usr/bin/env bash
# biodyn's main job on a fresh Debian machine: install what is missing, build (Release, all
# cores), then run the main job on the built-in default character. Re-running is incremental.
# The main job: the default character walks from standing under the torque walker with the
# honest foot weld. With a display, the interactive viewer opens on it (biodyn view); without
# one, a 10 s video and a frame are rendered headless (out/walk.mp4, out/walk.png) and the 20 s
# walk summary is printed (and written as JSON and a per-step CSV trace in out/).
# Extra arguments go to `biodyn walk` (e.g. ./run.sh --weld off --reaction-time 0.1
# --height 1.95 --mass 120 --duration 60) and to the viewer's scenario options.
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
./scripts/build.sh
mkdir -p out
./build/apps/biodyn model -o out/character.xml --summary out/character.json  # to look at
if [ -n "${DISPLAY:-}" ]; then
  exec ./build/apps/biodyn view --scenario walk "$@"
fi
./build/apps/biodyn walk --duration 20 --json out/walk.json --csv out/walk.csv "$@"
./build/apps/biodyn render --scenario walk --duration 10 -o out/walk.mp4 --png out/walk.png \
  --png-time 6 --summary out/render.json
