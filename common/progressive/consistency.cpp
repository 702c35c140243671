#include "progressive/consistency.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "util/input_error.h"

namespace pd {

namespace {

std::vector<char> obstacle_flags(const FrameReader& reader, std::size_t objects) {
  std::vector<char> flags(objects, 0);
  const nlohmann::json j = nlohmann::json::parse(reader.scene_json(), nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("objects") || !j["objects"].is_array() || j["objects"].size() != objects)
    return flags;
  for (std::size_t k = 0; k < objects; ++k) {
    const nlohmann::json& o = j["objects"][k];
    flags[k] = o.is_object() && o.contains("obstacle") && o["obstacle"].is_boolean() && o["obstacle"].get<bool>();
  }
  return flags;
}

}  // namespace

std::vector<LevelSeries> read_level_series(const FrameReader& reader) {
  std::vector<LevelSeries> out;
  for (int l = 0; l < reader.num_levels(); ++l) {
    const std::vector<uint8_t> done = reader.done(l);
    LevelSeries s;
    s.file = reader.path();
    s.level = l;
    s.object_names = reader.object_names(l);
    s.obstacle = obstacle_flags(reader, s.object_names.size());
    const std::vector<std::string> names = reader.stat_names(l);
    const bool has_ke = std::find(names.begin(), names.end(), "kinetic_energy") != names.end();
    const std::vector<double> ke = has_ke ? reader.stat(l, "kinetic_energy") : std::vector<double>();
    for (int t = 0; t < static_cast<int>(done.size()); ++t) {
      if (!done[static_cast<std::size_t>(t)]) continue;
      s.frames.push_back(t);
      s.com.push_back(reader.center_of_mass(l, t));
      s.kinetic_energy.push_back(has_ke ? ke[static_cast<std::size_t>(t)] : std::numeric_limits<double>::quiet_NaN());
    }
    if (!s.frames.empty()) out.push_back(std::move(s));
  }
  return out;
}

double com_distance(const ObjectPoints& a, const ObjectPoints& b, const std::vector<char>& obstacle) {
  double sum = 0.0;
  for (Eigen::Index k = 0; k < a.rows(); ++k)
    if (!obstacle[static_cast<std::size_t>(k)]) sum += (a.row(k) - b.row(k)).norm();
  return sum;
}

std::vector<std::pair<int, double>> com_deviation(const LevelSeries& a, const LevelSeries& ref) {
  if (a.object_names.size() != ref.object_names.size())
    throw InputError(a.file + " level " + std::to_string(a.level) + " has " + std::to_string(a.object_names.size()) +
                     " objects, " + ref.file + " level " + std::to_string(ref.level) + " has " +
                     std::to_string(ref.object_names.size()) + ": not the same scene");
  std::vector<std::pair<int, double>> out;
  std::size_t j = 0;
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    while (j < ref.frames.size() && ref.frames[j] < a.frames[i]) ++j;
    if (j == ref.frames.size()) break;
    if (ref.frames[j] != a.frames[i]) continue;
    out.emplace_back(a.frames[i], com_distance(a.com[i], ref.com[j], a.obstacle));
  }
  return out;
}

}  // namespace pd
