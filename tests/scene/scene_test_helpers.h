#pragma once
// Shared by the scene-file tests: a small valid scene to break one thing at a time, and checks that
// parsing fails with one InputError naming the file and the key path.
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scene/scene_file.h"
#include "util/input_error.h"

namespace pd::test {

using nlohmann::json;

inline const std::string kFile = "shots/test-scene.json";  // the name messages must carry

// A fresh directory under the system temp folder, removed at the end of the test.
class TempDir {
 public:
  TempDir()
      : path_(std::filesystem::temp_directory_path() / ("pd-scene-test-" + std::to_string(std::random_device{}()))) {
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string path() const { return path_.string(); }
  // Writes `text` (bytes as given) to path()/name, creating folders; returns the file's path.
  std::string write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = path_ / name;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }

 private:
  std::filesystem::path path_;
};

// A small valid scene; tests break one thing at a time.
inline json valid_scene() {
  return json::parse(R"({
    "format_version": 1,
    "time_step": 0.01,
    "frames": 10,
    "objects": [{
      "name": "sheet",
      "mesh": {"type": "rectangle", "size": [1.0, 1.0], "cells": [4, 4]},
      "material": {"density": 200, "youngs_modulus": 1e6, "poisson_ratio": 0.3, "thickness": 5e-4}
    }]
  })");
}

inline Scene parse(const json& scene, const std::string& base_dir = "") { return parse_scene(scene.dump(2), kFile, base_dir); }

// The message of the InputError that `run` throws ("" and a test failure if none).
template <class Run>
std::string error_of(Run run) {
  try {
    run();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

// Asserts parsing fails with a message that starts with the file and contains each of `parts`.
inline void expect_text_error(const std::string& text, std::initializer_list<std::string> parts,
                       const std::string& base_dir = "") {
  const std::string message = error_of([&] { parse_scene(text, kFile, base_dir); });
  EXPECT_EQ(message.rfind(kFile, 0), 0u) << "message does not start with the file: " << message;
  for (const std::string& part : parts) EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
}
inline void expect_error(const json& scene, std::initializer_list<std::string> parts, const std::string& base_dir = "") {
  expect_text_error(scene.dump(2), parts, base_dir);
}

}  // namespace pd::test
