// pd compare: how consistent the levels of one or two frame files are (PD figures 18-19): per frame
// and level the centres of mass and kinetic energy, and the summed centre-of-mass deviation from a
// reference level; printed as a summary per level and written in full as CSV.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "progressive/consistency.h"
#include "store/frame_store.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

// The scene's time step from the file's stored scene text (NaN when it cannot be read: the CSV's
// time column is then empty rather than wrong).
double time_step_of(const FrameReader& reader) {
  const nlohmann::json j = nlohmann::json::parse(reader.scene_json(), nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("time_step") && j["time_step"].is_number()) return j["time_step"].get<double>();
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

int compare(const CompareArgs& args) {
  std::vector<std::string> files = {args.file};
  if (!args.other.empty()) files.push_back(args.other);
  std::vector<LevelSeries> series;
  std::vector<double> steps;
  for (const std::string& f : files) {
    const FrameReader reader(f);
    for (LevelSeries& s : read_level_series(reader)) {
      series.push_back(std::move(s));
      steps.push_back(time_step_of(reader));
    }
  }
  // The reference: the finest level of the first file that holds frames.
  int ref = -1;
  for (std::size_t k = 0; k < series.size(); ++k)
    if (series[k].file == args.file) ref = static_cast<int>(k);
  if (ref < 0) throw InputError(args.file + ": no level holds a frame");
  const LevelSeries& reference = series[static_cast<std::size_t>(ref)];

  const std::string csv_path = args.csv.empty() ? args.file + ".compare.csv" : args.csv;
  std::ofstream csv(csv_path);
  if (!csv) throw InputError(csv_path + ": cannot write the CSV file");
  csv << "file,level,frame,time_s,kinetic_energy_J,com_deviation_m";
  for (const std::string& name : reference.object_names) csv << ",com_" << name << "_x,com_" << name << "_y,com_" << name << "_z";
  csv << "\n";
  csv.precision(17);

  std::printf("reference: %s level %d (centre-of-mass deviation = sum over simulated objects of |c - c_ref|)\n",
              reference.file.c_str(), reference.level);
  std::printf("%-40s %5s %7s %22s %14s %14s\n", "file", "level", "frames", "max deviation m (frame)", "mean dev. m",
              "last KE J");
  for (std::size_t k = 0; k < series.size(); ++k) {
    const LevelSeries& s = series[k];
    const std::vector<std::pair<int, double>> dev = com_deviation(s, reference);
    double max_dev = 0.0, sum = 0.0;
    int at = -1;
    for (const auto& [t, d] : dev) {
      sum += d;
      if (d > max_dev || at < 0) max_dev = d, at = t;
    }
    std::printf("%-40s %5d %7zu %13.4g (%5d) %14.4g %14.4g\n", s.file.c_str(), s.level, s.frames.size(), max_dev, at,
                dev.empty() ? 0.0 : sum / static_cast<double>(dev.size()), s.kinetic_energy.back());
    std::size_t d = 0;
    for (std::size_t i = 0; i < s.frames.size(); ++i) {
      const int t = s.frames[i];
      while (d < dev.size() && dev[d].first < t) ++d;
      csv << s.file << "," << s.level << "," << t << ",";
      if (std::isfinite(steps[k])) csv << t * steps[k];
      csv << "," << s.kinetic_energy[i] << ",";
      if (d < dev.size() && dev[d].first == t) csv << dev[d].second;
      for (Eigen::Index o = 0; o < s.com[i].rows(); ++o)
        csv << "," << s.com[i](o, 0) << "," << s.com[i](o, 1) << "," << s.com[i](o, 2);
      csv << "\n";
    }
  }
  csv.close();
  if (!csv) throw InputError(csv_path + ": writing the CSV file failed");
  std::printf("wrote %s\n", csv_path.c_str());
  return 0;
}

}  // namespace pd::cli
