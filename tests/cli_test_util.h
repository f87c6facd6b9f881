// Running the meshgauge CLI binary from tests.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace meshgauge::testing {

struct CliRun {
  int exit_code;
  std::string out;  // stdout, and stderr unless it was dropped.
};

// Runs `meshgauge ARGS REDIRECTIONS` through the shell; out is what reaches
// the shell's stdout.
inline CliRun RunCliRedirected(const std::string& args,
                               const std::string& redirections) {
  const std::string cmd =
      std::string(MESHGAUGE_CLI) + " " + args + " " + redirections;
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) out.append(buf, n);
  const int status = pclose(pipe);
  return {WEXITSTATUS(status), out};
}

// Runs `meshgauge ARGS` through the shell.
inline CliRun RunCli(const std::string& args, bool with_stderr = true) {
  return RunCliRedirected(args, with_stderr ? "2>&1" : "2>/dev/null");
}

// Runs `meshgauge ARGS` through the shell; out is its stderr alone.
inline CliRun RunCliStderr(const std::string& args) {
  return RunCliRedirected(args, "2>&1 >/dev/null");
}

// A path in the temporary directory unique to this process.
inline std::string Tmp(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("meshgauge_cli_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

}  // namespace meshgauge::testing
