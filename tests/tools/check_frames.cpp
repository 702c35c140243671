// pd_check_frames FILE.h5 [--level L]: checks every stored frame of a frame file with the
// independent CGAL intersection checker (tests/support/intersection_checker.h), for runs too long
// for the test suite. Prints one line per intersecting frame (then its first eight face pairs, by
// vertex index) and a summary; exit code 0 when every stored frame is intersection-free, 1 when some
// frame is not, 2 on bad input.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>

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
    for (int level = first; level <= last; ++level) {
      const pd::Faces F = reader.faces(level);
      const auto done = reader.done(level);
      for (int t = 0; t < reader.num_frames(); ++t) {
        if (!done[t]) continue;
        const auto report = pd::test::find_intersections(reader.frame(level, t), F);
        ++checked;
        if (report.intersecting_pairs > 0 || !report.degenerate_faces.empty()) {
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
