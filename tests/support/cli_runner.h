#pragma once
// Runs the `biodyn` executable as a user does, for the CLI tests.
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "test_support.h"

namespace biodyn::testing {

/// What one run of `biodyn` did.
struct CliRun {
  int exit_code = -1;
  std::string out, err;
};

/// The whole text of file `p` (empty if it does not exist).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Writes `text` to file `p` (a test's input file); the test fails if it cannot.
inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
  REQUIRE(out);
}

/// Runs the shell command `command` in `dir`, capturing stdout and stderr.
inline CliRun run_shell(const std::string& command, const std::filesystem::path& dir) {
  const std::string cmd = "cd '" + dir.string() + "' && " + command + " > stdout.txt 2> stderr.txt";
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(dir / "stdout.txt");
  r.err = slurp(dir / "stderr.txt");
  // In the sanitized build (./test.sh --sanitize) the `biodyn` run here is instrumented too: its
  // sanitizers' report fails the test, whatever exit code the test expects, and shows the report.
  for (const char* report :
       {"ERROR: AddressSanitizer", "ERROR: LeakSanitizer", ": runtime error: "}) {
    if (r.err.find(report) != std::string::npos) {
      FAIL_CHECK("sanitizer report from `" << command << "`:\n" << r.err);
      break;
    }
  }
  return r;
}

/// The shell prefix that runs a command under a virtual display (xvfb-run, 1280x720, killed
/// after 300 s). Display numbers start from one derived from this process's id: ctest runs test
/// cases in parallel, and two xvfb-run -a starting together at the same number collide.
/// The X authority file is the run directory's own (`-f`): left to itself, xvfb-run makes a
/// temporary directory and, when the command quits while the server is still resetting, fails
/// to remove it and exits 5 in place of the command's code (4 of 16 parallel runs here).
inline std::string under_xvfb() {
  const int first_display = 100 + static_cast<int>(getpid() % 800) * 4;
  return "timeout 300 xvfb-run -a -n " + std::to_string(first_display) +
         " -f xvfb.auth -s '-screen 0 1280x720x24' ";
}

/// Runs `biodyn <args>` in `dir`, capturing stdout and stderr.
inline CliRun run_biodyn(const std::string& args, const std::filesystem::path& dir) {
  return run_shell("'" + binary_dir() + "/apps/biodyn' " + args, dir);
}

/// An empty directory <build>/<group>/<name> for one test's files.
inline std::filesystem::path fresh_dir(const std::string& group, const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(binary_dir()) / group / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace biodyn::testing
