#pragma once
// Running the pd binary from tests (tests/client/): by shell (run_pd) or by exact argv with limits
// (run_pd_argv), the small scenes those tests share, and checks of what pd printed and wrote.
#include <sys/resource.h>

#include <set>
#include <string>
#include <vector>

namespace pd::cli_test {

struct CliResult {
  int exit_code;
  std::string output;  // stdout and stderr
};

// pd ARGS through the shell, stdout and stderr together, stdin /dev/null; exit code -1 when pd did
// not exit normally.
CliResult run_pd(const std::string& args);

// Writes `text` to dir/name; returns the path.
std::string write_file(const std::string& dir, const std::string& name, const std::string& text);

// A valid scene small enough to run in a second; tests break one thing at a time.
std::string small_scene(const std::string& material = R"("density": 200, "youngs_modulus": 1e5, "poisson_ratio": 0.3, "thickness": 0.001)",
                        const std::string& mesh = R"({"type": "rectangle", "size": [0.5, 0.5], "cells": [4, 4]})");

// A pinned 12 x 12 sheet above a small icosphere obstacle, 3 levels.
std::string hierarchy_scene();

// Vertex lines of an OBJ file; OBJ files in a folder.
int obj_vertex_count(const std::string& path);
int count_objs(const std::string& dir);

struct ArgvResult {
  int exit_code = -1;  // -1: killed (timeout) or did not exit normally
  std::string output;  // stdout and stderr
  double seconds = 0;
  bool timed_out = false;
};

// Runs pd with exactly these arguments (no shell: values may hold newlines and control characters),
// stdin /dev/null. Killed after timeout_s. fsize_limit > 0: the child's RLIMIT_FSIZE in bytes with
// SIGXFSZ ignored, so a write beyond it fails with EFBIG as on a full disk. term_when_exists: send
// SIGTERM 0.5 s after that file first exists.
ArgvResult run_pd_argv(const std::vector<std::string>& args, double timeout_s = 60, rlim_t fsize_limit = 0,
                       const std::string& term_when_exists = "");

// The arguments joined for messages, each cut at 100 characters.
std::string joined(const std::vector<std::string>& args);

// Exit 2 and exactly one line "pd: error: ...", without CLI11's "Run with --help" line.
void expect_one_line_error(const ArgvResult& r, const std::string& what);

// A file's bytes; the files under a folder, relative paths.
std::string file_bytes(const std::string& path);
std::set<std::string> listing(const std::string& dir);

}  // namespace pd::cli_test
