#!/usr/bin/env bash
# Same set-up as run.sh, then the whole test suite with ctest. Further arguments go to ctest
# (e.g. ./test.sh -LE slow).
# ./test.sh --sanitize [ctest args]: the same suite built with AddressSanitizer (with leak
# detection) and UndefinedBehaviorSanitizer in ./build-sanitize; the first finding aborts the
# process with a stack trace, so its test fails. The tests that run `biodyn` run the sanitized
# one (tests/support/cli_runner.h finds it in the build directory).
set -euo pipefail
cd "$(dirname "$0")"
./scripts/install_deps.sh
if [ "${1:-}" = "--sanitize" ]; then
  shift
  ./scripts/build.sh --sanitize
  # abort_on_error: a finding in a `biodyn` the tests run kills it with SIGABRT, never an exit
  # code (1 or 2) a test might expect. Leaks in third-party libraries: tests/sanitizer/lsan.supp.
  export ASAN_OPTIONS=halt_on_error=1:abort_on_error=1:detect_leaks=1:check_initialization_order=1:strict_init_order=1
  export UBSAN_OPTIONS=halt_on_error=1:abort_on_error=1:print_stacktrace=1
  export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizer/lsan.supp:print_suppressions=0"
  cd build-sanitize
else
  ./scripts/build.sh
  cd build
fi
ctest --output-on-failure -j "$(nproc)" "$@"
