#include "scheduler/job_files.h"

#include <filesystem>
#include <fstream>
#include <iterator>

#include "store/hierarchy_store.h"
#include "util/input_error.h"

namespace pd::scheduler {

namespace fs = std::filesystem;

JobFiles::JobFiles(std::string jobs_dir) : dir_(std::move(jobs_dir)) { fs::create_directories(dir_); }

std::string JobFiles::path_of(int64_t job) const { return dir_ + "/" + std::to_string(job) + ".h5"; }

JobFile& JobFiles::create(int64_t job, const std::string& scene_text, int frames, int levels, const std::string& hash,
                          const std::string& blob) {
  JobFile f;
  f.path = path_of(job);
  f.hierarchy_path = dir_ + "/" + std::to_string(job) + ".hierarchy.h5";
  {
    std::ofstream out(f.hierarchy_path, std::ios::binary | std::ios::trunc);
    out.write(blob.data(), static_cast<std::streamsize>(blob.size()));
    out.close();
    if (!out) throw InputError(f.hierarchy_path + ": cannot write the hierarchy file");
  }
  std::optional<SceneHierarchy> h = read_hierarchy(f.hierarchy_path);
  if (!h) throw InputError(f.hierarchy_path + ": /hierarchy@hash: the hierarchy task's file has no hierarchy");
  if (h->hash != hash)
    throw InputError(f.hierarchy_path + ": /hierarchy@hash: " + h->hash + ", the report says " + hash);
  if (h->num_levels() != levels)
    throw InputError(f.hierarchy_path + ": the hierarchy has " + std::to_string(h->num_levels()) +
                     " levels, the job asks for " + std::to_string(levels));
  const std::vector<std::string> names = FrameReader(f.hierarchy_path).object_names(0);
  f.writer = FrameWriter::create(f.path, scene_text, frames);
  write_hierarchy(f.path, *h, names);
  add_hierarchy_levels(*f.writer, *h, names);
  f.hierarchy_hash = hash;
  f.hierarchy_blob = blob;
  for (const SceneLevel& lv : h->levels) {
    f.vertices.push_back(static_cast<int>(lv.rest.V.rows()));
    f.objects.push_back(static_cast<int>(lv.vertex_offsets.size()) - 1);
  }
  files_.erase(job);
  return files_.emplace(job, std::move(f)).first->second;
}

JobFile* JobFiles::find(int64_t job) {
  auto it = files_.find(job);
  return it == files_.end() ? nullptr : &it->second;
}

std::string JobFiles::read_bytes(int64_t job) {
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
