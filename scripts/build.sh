#!/usr/bin/env bash
# Configure (once) and build biodyn in ./build, Release, on every core. Warnings are errors
# when CI=true (CI sets it), so a warning fails CI but not a user's first build.
# --sanitize: the same in ./build-sanitize with AddressSanitizer and UndefinedBehaviorSanitizer
# (BIODYN_SANITIZE), optimised (-O2) with line tables only (-g1): enough for the sanitizers'
# stack traces at a fraction of -g's compile time.
set -euo pipefail
cd "$(dirname "$0")/.."
werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
dir=build
config=(-DCMAKE_BUILD_TYPE=Release)
if [ "${1:-}" = "--sanitize" ]; then
  dir=build-sanitize
  config=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG"
          -DBIODYN_SANITIZE=ON)
fi
if [ ! -f "$dir/CMakeCache.txt" ] || ! grep -q "BIODYN_WARNINGS_AS_ERRORS:BOOL=${werror}" "$dir/CMakeCache.txt"; then
  cmake -S . -B "$dir" "${config[@]}" -DBIODYN_WARNINGS_AS_ERRORS="${werror}" >/dev/null
fi
cmake --build "$dir" --parallel "$(nproc)"
