#pragma once
// Consistency between levels (PD figures 18-19): how far each level's trajectory is from a
// reference level's, measured on the objects' centres of mass, which every frame file stores per
// frame (/levels/<l>/stats/center_of_mass, masses lumped on that level's mesh, so levels compare).
//
//   deviation(t) = sum over simulated objects k of | c_k(t) - c_k^ref(t) |_2      (m)
//
// Obstacles are left out: they follow their scripts on every level, and their stored "centre" is
// the vertex average of the level's mesh, which differs between levels by the decimation alone
// (1.3 mm for drape-sphere's sphere between two levels).
#include <string>
#include <vector>

#include "store/frame_store.h"

namespace pd {

// One level of one frame file: the frames it holds and their centres of mass and kinetic energy.
struct LevelSeries {
  std::string file;
  int level = 0;
  std::vector<std::string> object_names;
  std::vector<char> obstacle;          // per object, from the stored scene ("obstacle": true)
  std::vector<int> frames;             // stored frames, increasing
  std::vector<ObjectPoints> com;       // per stored frame, (objects, 3) m
  std::vector<double> kinetic_energy;  // per stored frame, J (NaN if not recorded)
};

// Every level of `reader` that holds at least one frame, coarsest first; obstacle flags from the
// scene text stored in the file (an unreadable scene text counts every object as simulated).
std::vector<LevelSeries> read_level_series(const FrameReader& reader);

// The deviation rule for one frame: sum over objects k with obstacle[k] == 0 of |a_k - b_k| (m).
// a, b: (objects, 3) centres of mass; obstacle: one flag per object.
double com_distance(const ObjectPoints& a, const ObjectPoints& b, const std::vector<char>& obstacle);

// deviation(t) of `a` against `ref` for every frame both hold, as (frame, metres) pairs in frame
// order. Throws InputError (naming both files and levels) when their object counts differ.
std::vector<std::pair<int, double>> com_deviation(const LevelSeries& a, const LevelSeries& ref);

}  // namespace pd
