#include "scheduler/job_files.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "store/hierarchy_store.h"
#include "util/fnv1a.h"
#include "util/input_error.h"
#include "util/subprocess.h"

namespace pd::scheduler {

namespace fs = std::filesystem;

JobFiles::JobFiles(std::string jobs_dir, std::string checker) : dir_(std::move(jobs_dir)), checker_(std::move(checker)) {
  fs::create_directories(dir_);
}

std::string JobFiles::path_of(int64_t job) const { return dir_ + "/" + std::to_string(job) + ".h5"; }

namespace {

FrameStats as_frame_stats(const FrameData& d) {
  FrameStats stats;
  stats.scalars = d.stats;
  if (!d.center_of_mass.empty())
    stats.center_of_mass = Eigen::Map<const ObjectPoints>(d.center_of_mass.data(),
                                                          static_cast<Eigen::Index>(d.center_of_mass.size() / 3), 3);
  return stats;
}

void write_into(FrameWriter& w, int level, int t, const FrameData& d) {
  w.write_frame(level, t,
                Eigen::Map<const Positions>(d.positions.data(), static_cast<Eigen::Index>(d.positions.size() / 3), 3),
                as_frame_stats(d));
}

}  // namespace

void check_frame_stats(const std::vector<protocol::Stat>& stats) {
  std::set<std::string> seen;
  for (const auto& [name, value] : stats) {
    if (!valid_stat_name(name)) throw InputError("frame: stats: invalid statistic name '" + name + "'");
    if (!seen.insert(name).second) throw InputError("frame: stats: '" + name + "': statistic given twice");
  }
}

SceneHierarchy check_hierarchy_file(const std::string& path, const std::string& hash, int levels) {
  std::optional<SceneHierarchy> h = read_hierarchy(path);
  if (!h) throw InputError(path + ": /hierarchy@hash: the hierarchy task's file has no hierarchy");
  if (h->hash != hash) throw InputError(path + ": /hierarchy@hash: " + h->hash + ", the report says " + hash);
  if (h->num_levels() != levels)
    throw InputError(path + ": the hierarchy has " + std::to_string(h->num_levels()) + " levels, the job asks for " +
                     std::to_string(levels));
  FrameReader(path).object_names(0);  // what JobFiles::create reads besides
  return std::move(*h);
}

void check_hierarchy_in_child(const std::string& self, const std::string& path, const std::string& hash, int levels) {
  const CommandResult r = run_command({self, "--check-hierarchy", path, "--hash", hash, "--levels", std::to_string(levels)},
                                      std::chrono::seconds(10));
  if (r.exit_code == 0 && !r.timed_out) return;
  if (const std::optional<std::string> refused = check_refusal(r, "pd-scheduler: error: ")) throw InputError(*refused);
  throw InputError(path + ": the hierarchy file could not be read: " +
                   (r.failure.empty() ? "its check exited " + std::to_string(r.exit_code) : r.failure) +
                   (r.exit_code > 128 ? " (killed by signal " + std::to_string(r.exit_code - 128) + ")" : ""));
}

void JobFiles::write_frame(JobFile& f, int level, int t, const FrameData& data) { write_into(*f.writer, level, t, data); }

JobFile& JobFiles::create(int64_t job, const std::string& scene_text, int frames, int levels, const std::string& hash,
                          const std::string& blob, std::size_t count,
                          const std::function<StoredFrame(std::size_t)>& frame) {
  JobFile f;
  f.path = path_of(job);
  f.hierarchy_path = dir_ + "/" + std::to_string(job) + ".hierarchy.h5";
  {
    std::ofstream out(f.hierarchy_path, std::ios::binary | std::ios::trunc);
    out.write(blob.data(), static_cast<std::streamsize>(blob.size()));
    out.close();
    if (!out) throw InputError(f.hierarchy_path + ": cannot write the hierarchy file");
  }
  if (!checker_.empty()) {
    Fnv1a digest;
    digest.bytes(blob.data(), blob.size());
    const auto [lo, hi] = checked_.equal_range(digest.value());
    if (std::none_of(lo, hi, [&](const auto& c) { return c.second == blob; })) {
      check_hierarchy_in_child(checker_, f.hierarchy_path, hash, levels);
      checked_.emplace(digest.value(), blob);
    }
  }
  const SceneHierarchy h = check_hierarchy_file(f.hierarchy_path, hash, levels);
  const std::vector<std::string> names = FrameReader(f.hierarchy_path).object_names(0);
  const std::string building = f.path + ".tmp";
  files_.erase(job);  // closes the file a rebuild replaces
  f.writer = FrameWriter::create(building, scene_text, frames);
  // Frames are durable in the task store; the file is flushed when read (fetch), when its job ends
  // and when the scheduler stops (two flushes per frame were the farm's bottleneck).
  f.writer->set_flush_each_frame(false);
  write_hierarchy(building, h, names);
  add_hierarchy_levels(*f.writer, h, names);
  for (std::size_t i = 0; i < count; ++i) {
    const StoredFrame s = frame(i);
    write_into(*f.writer, s.first.level, s.first.frame, s.second);
  }
  f.writer->flush();
  // The open writer follows the file (same inode) through the rename.
  std::error_code ec;
  fs::rename(building, f.path, ec);
  if (ec) throw InputError(f.path + ": cannot replace the job file: " + ec.message());
  f.hierarchy_hash = hash;
  f.hierarchy_blob = blob;
  for (const SceneLevel& lv : h.levels) {
    f.vertices.push_back(static_cast<int>(lv.rest.V.rows()));
    f.objects.push_back(static_cast<int>(lv.vertex_offsets.size()) - 1);
  }
  return files_.emplace(job, std::move(f)).first->second;
}

JobFile* JobFiles::find(int64_t job) {
  auto it = files_.find(job);
  return it == files_.end() ? nullptr : &it->second;
}

void JobFiles::flush(int64_t job) {
  JobFile* f = find(job);
  if (f && f->writer) f->writer->flush();
}

std::string JobFiles::read_bytes(int64_t job) {
  flush(job);
  const std::string path = path_of(job);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the job file");
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void JobFiles::close_all() {
  for (auto& [job, f] : files_)
    if (f.writer) f.writer->close();
}

}  // namespace pd::scheduler
