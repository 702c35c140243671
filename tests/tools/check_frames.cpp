// pd_check_frames FILE.h5 [--level L]: checks every stored frame of a frame file with the
// independent CGAL intersection checker (tests/support/intersection_checker.h), for runs too long
// for the test suite. Pairs of faces inside one obstacle are left out (an animated body's parts may
// cross, as captured bodies' do; the obstacle flags come from the stored scene). Prints one line per
// intersecting frame (then its first eight face pairs, by vertex index) and a summary; exit code 0
// when every stored frame is intersection-free, 1 when some frame is not, 2 on bad input.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

#include <nlohmann/json.hpp>

#include "store/frame_store.h"
#include "support/intersection_checker.h"
#include "util/input_error.h"

int main(int argc, char** argv) {
  if (argc != 2 && !(argc == 4 && std::strcmp(argv[2], "--level") == 0)) {
    std::fprintf(stderr, "usage: pd_check_frames FILE.h5 [--level L]\n");
    return 2;
  }
  try {
    const pd::FrameReader reader(argv[1]);
    int first = 0, last = reader.num_levels() - 1;
    if (argc == 4) first = last = std::stoi(argv[3]);
    int checked = 0, bad = 0;
    const nlohmann::json scene = nlohmann::json::parse(reader.scene_json(), nullptr, false);
    for (int level = first; level <= last; ++level) {
      const pd::Faces F = reader.faces(level);
      const auto done = reader.done(level);
      // Objects' faces are stacked in object order: object k's are those whose first vertex is its.
      const std::vector<int> vertex_offsets = reader.object_offsets(level);
      std::vector<int> face_offsets = {0};
      std::vector<char> obstacle;
      for (std::size_t k = 0; k + 1 < vertex_offsets.size(); ++k) {
        int f = face_offsets.back();
        while (f < F.rows() && F(f, 0) < vertex_offsets[k + 1]) ++f;
        face_offsets.push_back(f);
        const nlohmann::json* o = scene.is_object() && scene.contains("objects") && scene["objects"].is_array() &&
                                          k < scene["objects"].size()
                                      ? &scene["objects"][k]
                                      : nullptr;
        obstacle.push_back(o && o->is_object() && o->value("obstacle", false) ? 1 : 0);
      }
      for (int t = 0; t < reader.num_frames(); ++t) {
        if (!done[t]) continue;
        const pd::Positions x = reader.frame(level, t);
        ++checked;
        if (pd::test::intersections_outside_obstacles(x, F, face_offsets, obstacle) > 0) {
          const auto report = pd::test::find_intersections(x, F);
          ++bad;
          std::printf("level %d frame %d: %d intersecting face pairs, %zu degenerate faces\n", level, t,
                      report.intersecting_pairs, report.degenerate_faces.size());
          // The first pairs by their faces' vertex indices, to find the objects and the place.
          const std::size_t shown = std::min<std::size_t>(report.face_pairs.size(), 8);
          for (std::size_t k = 0; k < shown; ++k) {
            const auto [f, g] = report.face_pairs[k];
            std::printf("  faces %d (%d %d %d) and %d (%d %d %d)\n", f, F(f, 0), F(f, 1), F(f, 2), g, F(g, 0),
                        F(g, 1), F(g, 2));
          }
        }
      }
    }
    std::printf("%s: %d frames checked, %d intersecting\n", argv[1], checked, bad);
    return bad ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd_check_frames: error: %s\n", e.what());
    return 2;
  }
}
