#pragma once
// The scheduler's job files: FARM_DIR/jobs/<job>.h5, the frame file of docs/frame-format.md (the
// same layout `pd simulate` writes), of which the scheduler is the only writer, and beside it
// <job>.hierarchy.h5, the hierarchy as the hierarchy task built it (the bytes shipped to workers).
//
// Order of durability: the task store records a frame with its data first, then it is written here
// (scheduler/worker_reports.cpp), without a flush of its own: the file is flushed when fetched, when
// its job ends and when the scheduler stops. A job file is (re)built whole in <job>.h5.tmp and
// renamed over <job>.h5, so a reader never sees a half-built file; a scheduler killed while writing
// a frame leaves a file that the next scheduler rebuilds from the store (Scheduler::recover).
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hierarchy/scene_hierarchy.h"
#include "store/frame_store.h"
#include "store/task_store.h"

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

// A frame the task store holds, to write into a job file being built.
using StoredFrame = std::pair<FrameKey, FrameData>;

// The hierarchy file at `path` as a hierarchy task sent it: readable, with the hierarchy hash `hash`
// and `levels` levels. Returns it; InputError naming the file otherwise. It parses bytes a worker
// sent with HDF5, which some crafted files crash (fuzz/known_hdf5_bugs): the scheduler runs it in a
// child process first (check_hierarchy_in_child), and only then in its own.
SceneHierarchy check_hierarchy_file(const std::string& path, const std::string& hash, int levels);

// check_hierarchy_file in a child process (this program run again with --check-hierarchy, bounded in
// time and memory): InputError with its message when it refuses the file, or saying how it ended
// when it crashed or ran out of time. `self`: this program's path (/proc/self/exe).
void check_hierarchy_in_child(const std::string& self, const std::string& path, const std::string& hash, int levels);

// InputError when a frame's statistics cannot go into a job file (an empty name, one with '/',
// "center_of_mass", or a name twice): checked before the store records the frame.
void check_frame_stats(const std::vector<protocol::Stat>& stats);

class JobFiles {
 public:
  // checker: this program's path; non-empty, every hierarchy blob is read first in a child process
  // (check_hierarchy_in_child) before this process parses it.
  explicit JobFiles(std::string jobs_dir, std::string checker = "");

  // Creates the job file from a hierarchy task's result: writes the blob to <job>.hierarchy.h5,
  // reads it back (which checks every operator; InputError when the blob is not a hierarchy of
  // `levels` levels with hash `hash`), then creates <job>.h5 with the scene text, the hierarchy and
  // every level's frame datasets for frames 0..frames, holding the `count` frames frame(0) ..
  // frame(count - 1) (a rebuild from the store; none for a new job).
  JobFile& create(int64_t job, const std::string& scene_text, int frames, int levels, const std::string& hash,
                  const std::string& blob, std::size_t count = 0,
                  const std::function<StoredFrame(std::size_t)>& frame = {});

  // Writes and flushes a frame (InputError for a level or frame out of range or a bad statistic).
  void write_frame(JobFile& f, int level, int t, const FrameData& data);

  // The job's file, or nullptr while its hierarchy is not built.
  JobFile* find(int64_t job);

  // Flushes the job's file (frames are written without a flush each: the store has them).
  void flush(int64_t job);

  // The file's bytes as stored so far (flushed first, so this is a valid file).
  std::string read_bytes(int64_t job);

  std::string path_of(int64_t job) const;

  // Closes every open writer (on scheduler exit).
  void close_all();

 private:
  std::string dir_;
  std::string checker_;
  // Hierarchy files the child check passed, by their bytes' FNV-1a: a file equal byte for byte to
  // one of them parses the same and is not checked again (jobs of one scene share their hierarchy;
  // the check costs a process start, 24 ms here, 124 ms in the sanitizer build). Equality is of the
  // bytes, not the digest alone, which is not collision-proof.
  std::multimap<std::uint64_t, std::string> checked_;
  std::map<int64_t, JobFile> files_;
};

}  // namespace pd::scheduler
