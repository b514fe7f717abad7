#!/usr/bin/env bash
# Configure (once) and build biodyn in ./build, Release, on every core. Warnings are errors
# when CI=true (CI sets it), so a warning fails CI but not a user's first build.
set -euo pipefail
cd "$(dirname "$0")/.."
werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
if [ ! -f build/CMakeCache.txt ] || ! grep -q "BIODYN_WARNINGS_AS_ERRORS:BOOL=${werror}" build/CMakeCache.txt; then
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DBIODYN_WARNINGS_AS_ERRORS="${werror}" >/dev/null
fi
cmake --build build --parallel "$(nproc)"
