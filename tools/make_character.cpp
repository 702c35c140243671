// pd_make_character: writes a garment shot on a generated walking character (tools/character.h):
// the body's rest OBJ and its PC2 cache, the skirt's OBJ and the scene file. scenes/skirt-walk/ is its
// output at the default options; bench/scenes/skirt-walk-large/ is made by bench/skirt_walk.sh.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "tools/character.h"

int main(int argc, char** argv) {
  CLI::App app{"Write a skirt shot on a generated walking character (tools/README.md)"};
  std::string out, name = "skirt-walk";
  pd::tools::CharacterOptions o;
  int frames = 150, levels = 3;
  app.add_option("--out", out, "Folder to write the shot into (created)")->required();
  app.add_option("--name", name, "Scene name (the scene file is OUT/NAME.json)");
  app.add_option("--segments", o.segments, "Vertices around each body capsule")->check(CLI::Range(4, 256));
  app.add_option("--skirt-around", o.skirt_around, "Skirt vertices around")->check(CLI::Range(8, 2048));
  app.add_option("--skirt-down", o.skirt_down, "Skirt face rows from waist to hem")->check(CLI::Range(1, 2048));
  app.add_option("--seconds", o.seconds, "Length of the body's animation, s")->check(CLI::Range(0.1, 600.0));
  app.add_option("--fps", o.fps, "Cache frames per second")->check(CLI::Range(1.0, 1000.0));
  app.add_option("--frames", frames, "Shot frames of 1/100 s (at most seconds x 100)")->check(CLI::Range(1, 60000));
  app.add_option("--levels", levels, "Hierarchy levels of the scene")->check(CLI::Range(1, 8));
  CLI11_PARSE(app, argc, argv);
  if (frames > o.seconds * 100.0 + 1e-9) {
    std::fprintf(stderr, "pd_make_character: error: --frames %d at 1/100 s outlast the %g s animation\n", frames, o.seconds);
    return 2;
  }
  try {
    const pd::tools::Character c = pd::tools::make_character(o);
    pd::tools::write_shot(c, o, out, name, frames, levels);
    std::printf("%s/%s.json: skirt %lld vertices, body %lld vertices, %zu cache frames at %g fps\n", out.c_str(),
                name.c_str(), static_cast<long long>(c.skirt.V.rows()), static_cast<long long>(c.body.V.rows()),
                c.frames.size(), o.fps);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pd_make_character: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
