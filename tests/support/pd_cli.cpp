#include "support/pd_cli.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>

#include <gtest/gtest.h>

#include "support/test_paths.h"

namespace pd::cli_test {

CliResult run_pd(const std::string& args) {
  const std::string cmd = test::pd_binary() + " " + args + " 2>&1 < /dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string small_scene(const std::string& material, const std::string& mesh) {
  return R"({"format_version": 1, "name": "small", "time_step": 0.01, "frames": 3,
  "objects": [{"name": "sheet", "mesh": )" + mesh + R"(, "material": {)" + material + R"(},
               "pins": [{"indices": [20, 24]}]}]})";
}

std::string hierarchy_scene() {
  return R"({"format_version": 1, "name": "hier", "time_step": 0.01, "frames": 3,
    "hierarchy": {"levels": 3}, "contact": {"dhat": 1e-3},
    "objects": [
      {"name": "sheet", "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [12, 12]},
       "material": {"preset": "cotton"}, "pins": [{"indices": [0, 12]}]},
      {"name": "ball", "mesh": {"type": "icosphere", "radius": 0.2, "subdivisions": 2}, "obstacle": true,
       "transform": {"translation": [0, 0, -1]}}]})";
}

int obj_vertex_count(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) n += line.rfind("v ", 0) == 0;
  return n;
}

int count_objs(const std::string& dir) {
  int objs = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) objs += e.path().extension() == ".obj";
  return objs;
}

ArgvResult run_pd_argv(const std::vector<std::string>& args, double timeout_s, rlim_t fsize_limit,
                       const std::string& term_when_exists) {
  ArgvResult r;
  int fds[2];
  if (pipe(fds) != 0) return r;
  const std::string bin = test::pd_binary();
  std::vector<char*> argv{const_cast<char*>(bin.c_str())};
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    close(fds[0]);
    close(fds[1]);
    const int in = open("/dev/null", O_RDONLY);
    dup2(in, 0);
    if (fsize_limit > 0) {
      signal(SIGXFSZ, SIG_IGN);  // kept across exec
      const rlimit lim{fsize_limit, fsize_limit};
      setrlimit(RLIMIT_FSIZE, &lim);
    }
    execv(bin.c_str(), argv.data());
    _exit(127);
  }
  close(fds[1]);
  const auto deadline = t0 + std::chrono::duration<double>(timeout_s);
  std::array<char, 4096> buf;
  std::optional<std::chrono::steady_clock::time_point> term_at;
  bool termed = false;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now);
    if (left.count() <= 0) {
      r.timed_out = true;
      kill(pid, SIGKILL);
      break;
    }
    if (!term_when_exists.empty() && !term_at && std::filesystem::exists(term_when_exists))
      term_at = now + std::chrono::milliseconds(500);
    if (term_at && !termed && now >= *term_at) termed = kill(pid, SIGTERM) == 0;
    pollfd p{fds[0], POLLIN, 0};
    const int wait_ms = term_when_exists.empty() ? static_cast<int>(left.count()) : 20;
    if (poll(&p, 1, std::min(wait_ms, static_cast<int>(left.count()))) <= 0) continue;
    const ssize_t n = read(fds[0], buf.data(), buf.size());
    if (n <= 0) break;
    r.output.append(buf.data(), static_cast<size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!r.timed_out && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  return r;
}

std::string joined(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) out += (out.empty() ? "" : " ") + a.substr(0, 100);
  return out;
}

void expect_one_line_error(const ArgvResult& r, const std::string& what) {
  EXPECT_EQ(r.exit_code, 2) << what << ": " << r.output;
  EXPECT_EQ(r.output.rfind("pd: error: ", 0), 0u) << what << ": " << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << what << ": " << r.output;
  EXPECT_EQ(r.output.find("--help"), std::string::npos) << what << ": " << r.output;
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::set<std::string> listing(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    names.insert(std::filesystem::relative(e.path(), dir).string());
  return names;
}

}  // namespace pd::cli_test
