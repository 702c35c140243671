#pragma once
// The scheduler's job files: FARM_DIR/jobs/<job>.h5, the frame file of docs/frame-format.md (the
// same layout `pd simulate` writes), of which the scheduler is the only writer, and beside it
// <job>.hierarchy.h5, the hierarchy as the hierarchy task built it (the bytes shipped to workers).
//
// Order of durability: a frame is written and flushed here before the task store records it
// (scheduler.cpp), so a frame the store calls stored is always in the file.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "store/frame_store.h"

namespace pd::scheduler {

struct JobFile {
  std::string path;            // jobs/<job>.h5
  std::string hierarchy_path;  // jobs/<job>.hierarchy.h5
  std::string hierarchy_hash;
  std::string hierarchy_blob;  // the hierarchy file's bytes, sent to workers that lack the hash
  std::vector<int> vertices;   // per level
  std::vector<int> objects;    // objects per level (the same for every level)
  std::optional<FrameWriter> writer;
};

class JobFiles {
 public:
  explicit JobFiles(std::string jobs_dir);

  // Creates the job file from a hierarchy task's result: writes the blob to <job>.hierarchy.h5,
  // reads it back (which checks every operator; InputError when the blob is not a hierarchy of
  // `levels` levels with hash `hash`), then creates <job>.h5 with the scene text, the hierarchy and
  // every level's (empty) frame datasets for frames 0..frames.
  JobFile& create(int64_t job, const std::string& scene_text, int frames, int levels, const std::string& hash,
                  const std::string& blob);

  // The job's file, or nullptr while its hierarchy is not built.
  JobFile* find(int64_t job);

  // The file's bytes as stored so far (every frame written is flushed, so this is a valid file).
  std::string read_bytes(int64_t job);

  std::string path_of(int64_t job) const;

  // Closes every open writer (on scheduler exit).
  void close_all();

 private:
  std::string dir_;
  std::map<int64_t, JobFile> files_;
};

}  // namespace pd::scheduler
