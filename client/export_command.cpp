// pd export: frames of a frame file as files other tools read.
#include <cstdio>

#include "commands.h"
#include "store/frame_store.h"
#include "util/input_error.h"

namespace pd::cli {

int export_frames(const ExportArgs& args) {
  const FrameReader reader(args.file);
  if (args.level < 0 || args.level >= reader.num_levels())
    throw InputError(args.file + ": --level " + std::to_string(args.level) + ": the file has levels 0.." +
                     std::to_string(reader.num_levels() - 1));
  if (args.format != "obj") throw InputError("--format " + args.format + ": supported formats: obj");
  const int n = export_obj_frames(reader, args.level, args.out_dir);
  std::printf("wrote %d OBJ frames of level %d to %s\n", n, args.level, args.out_dir.c_str());
  return 0;
}

}  // namespace pd::cli
