#!/usr/bin/env bash
# Installs the Debian packages biodyn needs that are missing (README, "Dependencies").
# Root on our machines; sudo otherwise. Does nothing when everything is present.
set -euo pipefail

packages=(
  build-essential cmake pkg-config   # toolchain
  libmujoco-dev libqhull-dev         # MuJoCo 2.2.2 (its CMake config names qhull's headers)
  libmujoco-samples                  # mujoco-compile: independent compile check in tests
  libeigen3-dev                      # vectors, quaternions, inertia tensors
  libtinyxml2-dev                    # MJCF built through a DOM
  nlohmann-json3-dev                 # JSON inputs (overrides) and outputs (summaries)
  libcli11-dev                       # the biodyn command line
  catch2                             # tests (Catch2 v2)
  gnuplot-nox                        # plots (push-sweep polar.png), driven as a process
  libegl-dev libegl-mesa0 libgl-dev  # OpenGL for MuJoCo's renderer; EGL renders without a display
  libgl1-mesa-dri                    # Mesa's software rasteriser (llvmpipe) where there is no GPU
  libstb-dev                         # PNG screenshots (stb_image_write)
  ffmpeg                             # MP4 videos (biodyn render), fed frames through a pipe
  libglfw3-dev libimgui-dev          # the interactive viewer's window and panels
  xvfb xauth xdotool                 # the viewer's tests: a virtual display, and a mouse to drag with
  clang-format pmccabe               # the house check (scripts/check_house.sh): format, function length
  chromium                           # tests open biodyn evaluate's HTML report in a real browser (headless)
  libopencv-dev                      # optical capture (mocap_io/capture): images, blobs, calibration, video, V4L2
  libceres-dev                       # optical capture: bundle adjustment of the camera rig
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "biodyn: installing missing Debian packages: ${missing[*]}" >&2
if [ "$(id -u)" -eq 0 ]; then SUDO=(); else SUDO=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -qq
"${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
