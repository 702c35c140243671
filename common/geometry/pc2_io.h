#pragma once
// Reading PC2 point caches (the vertex animation format of Blender's Mesh Cache modifier, 3ds Max's
// Point Cache and Maya's point cache export), for deforming obstacles (scene/vertex_animation.h).
// Layout, all little-endian:
//   char[12] "POINTCACHE2\0", int32 file version (1), int32 number of points, float32 start frame,
//   float32 sample rate (frames per sample), int32 number of samples   (32 bytes)
//   then, sample after sample, each point's x, y, z as float32          (samples x points x 12 bytes)
// (The writer, for `pd export --format pc2` and the character generator, is geometry/pc2_writer.h.)
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/mesh.h"

namespace pd {

struct Pc2Cache {
  float start_frame = 0.0f;  // as stored (a frame number of the program that wrote it)
  float sample_rate = 1.0f;  // frames per sample, > 0
  std::vector<Positions> samples;  // each (points, 3), in the file's units
};

struct Pc2Limits {
  std::uintmax_t max_bytes = std::uintmax_t{1} << 30;  // file size (1 GiB), checked by stat before opening
};

// Reads `path`. Everything the header promises is checked against the file's size before anything
// is allocated: the file must hold exactly 32 + 12 x points x samples bytes. Throws InputError
// naming the file and the field, sample or byte offset for: a path that is not a regular file, a
// file over the limit, a wrong signature or version, zero or negative counts, a start frame or
// sample rate that is not finite (or a sample rate <= 0), a size that does not match the header, and
// a coordinate that is not finite ("<path>: sample 3, point 17, y (byte 1268): not finite").
Pc2Cache read_pc2(const std::string& path, const Pc2Limits& limits = {});

}  // namespace pd
