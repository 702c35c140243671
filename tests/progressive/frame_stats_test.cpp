#include "progressive/frame_stats.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace pd {
namespace {

std::map<std::string, double> by_name(const FrameStats& s) {
  std::map<std::string, double> m;
  for (const auto& [name, value] : s.scalars) {
    EXPECT_TRUE(m.emplace(name, value).second) << "statistic " << name << " stored twice";
  }
  return m;
}

// A frame whose every reported figure is distinct, so a statistic read from the wrong field shows.
FrameRecord busy_frame() {
  FrameRecord r;
  r.frame = 3;
  r.seconds = 0.5;
  r.kinetic_energy = 1.5;
  r.pin_rounds = 2;
  r.newton.iterations = 11;
  r.newton.line_search_cuts = 3;
  r.newton.exact_hessians = 7;
  r.newton.projection_fallbacks = 4;
  r.newton.extended_steps = 5;
  r.newton.exact_curvature_iterations = 9;
  r.newton.curvature_probes = 6;
  r.newton.converged = false;
  r.newton.assemble_seconds = 0.125;
  r.newton.analyse_seconds = 0.0625;
  r.newton.factorize_seconds = 0.25;
  r.energies = {{"membrane", 2.5}, {"bending", 0.75}};
  r.contact = {{"contact_min_gap", 1e-4}};
  return r;
}

// What frame_stats must store for busy_frame(), by name.
std::map<std::string, double> busy_frame_stats() {
  return {
      {"newton_iterations", 11}, {"line_search_cuts", 3}, {"exact_hessians", 7},
      {"projection_fallbacks", 4}, {"extended_steps", 5}, {"exact_curvature_iterations", 9}, {"curvature_probes", 6},
      {"newton_converged", 0},
      {"solve_seconds", 0.5}, {"assemble_seconds", 0.125},
      {"factorize_seconds", 0.0625 + 0.25},  // symbolic analysis and numeric factorization together
      {"kinetic_energy", 1.5}, {"energy_membrane", 2.5}, {"energy_bending", 0.75},
      {"contact_min_gap", 1e-4}, {"pin_rounds", 2}};
}

TEST(FrameStats, EveryNewtonCountAndTimeIsStoredUnderItsOwnName) {
  const auto m = by_name(frame_stats(busy_frame()));
  const auto expected = busy_frame_stats();
  for (const auto& [name, value] : expected) {
    ASSERT_TRUE(m.count(name)) << name;
    EXPECT_EQ(m.at(name), value) << name;
  }
  EXPECT_EQ(m.size(), expected.size()) << "a statistic this test does not know about";
}

TEST(FrameStats, FrameZeroIsStoredAsConvergedWithoutASolve) {
  FrameRecord r;  // frame 0: the initial state, an empty Newton report
  const auto m = by_name(frame_stats(r));
  EXPECT_EQ(m.at("newton_converged"), 1.0);
  EXPECT_EQ(m.at("newton_iterations"), 0.0);
}

// Every name the simulator stores is in the frame format's table, so a reader of a frame file can
// look up what it means (energy_<term> is documented once, as a pattern).
TEST(FrameStats, EveryStoredNameIsDocumentedInTheFrameFormat) {
  std::ifstream in(std::string(PD_SOURCE_DIR) + "/docs/frame-format.md");
  ASSERT_TRUE(in) << "docs/frame-format.md";
  std::stringstream text;
  text << in.rdbuf();
  int checked = 0;
  for (const auto& [name, value] : frame_stats(busy_frame()).scalars) {
    const std::string documented = name.rfind("energy_", 0) == 0 ? "energy_<term>" : name;
    EXPECT_NE(text.str().find("| `" + documented + "` |"), std::string::npos) << name;
    ++checked;
  }
  EXPECT_EQ(checked, static_cast<int>(busy_frame_stats().size())) << "every statistic was looked up";
}

}  // namespace
}  // namespace pd
