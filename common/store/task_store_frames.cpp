// The task store's frames and guide frames (store/task_store.h); the rest of the store is in
// task_store.cpp. Every method is one transaction, as there.
#include <nlohmann/json.hpp>

#include "store/task_store_internal.h"

namespace pd {

using namespace task_store_internal;

void TaskStore::record_frame(int64_t job, const FrameKey& key, const FrameData& data) {
  Db& db = impl_->db;
  impl_->write("record_frame", [&] {
    check_frame(db, "record_frame", job, job_info(db, job), key);
    nlohmann::json names = nlohmann::json::array();
    std::vector<double> values;
    for (const auto& [name, value] : data.stats) {
      names.push_back(name);
      values.push_back(value);
    }
    run_sql(db, "INSERT INTO frames(job_id, level, frame, kappa, positions, stat_names, stat_values, center_of_mass) "
            "VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) ON CONFLICT(job_id, level, frame) DO UPDATE SET "
            "kappa = excluded.kappa, positions = excluded.positions, stat_names = excluded.stat_names, "
            "stat_values = excluded.stat_values, center_of_mass = excluded.center_of_mass",
            job, key.level, key.frame, data.kappa, doubles_blob(data.positions), names.dump(), doubles_blob(values),
            doubles_blob(data.center_of_mass));
    promote(db, job);
  });
}

std::optional<FrameData> TaskStore::frame_data(int64_t job, const FrameKey& key) const {
  Db& db = impl_->db;
  return impl_->read("frame_data", [&]() -> std::optional<FrameData> {
    check_frame(db, "frame_data", job, job_info(db, job), key);
    Statement st(db, "SELECT kappa, positions, stat_names, stat_values, center_of_mass FROM frames "
                     "WHERE job_id = ?1 AND level = ?2 AND frame = ?3");
    if (!st.bind_all(job, key.level, key.frame).step()) return std::nullopt;
    FrameData d;
    d.kappa = st.column_optional_double(0);
    d.positions = blob_doubles(db, st.column_blob(1), "positions");
    const std::vector<double> values = blob_doubles(db, st.column_blob(3), "stat_values");
    nlohmann::json names;
    try {
      names = nlohmann::json::parse(st.column_text(2));
    } catch (const nlohmann::json::exception& e) {
      db.fail_with("job " + str(job) + ": frame stat_names: " + e.what());
    }
    if (!names.is_array() || names.size() != values.size())
      db.fail_with("job " + str(job) + ": frame stat_names: not an array of one name per value");
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (!names[i].is_string()) db.fail_with("job " + str(job) + ": frame stat_names: not a string");
      d.stats.emplace_back(names[i].get<std::string>(), values[i]);
    }
    d.center_of_mass = blob_doubles(db, st.column_blob(4), "center_of_mass");
    return d;
  });
}

std::vector<FrameKey> TaskStore::frame_keys(int64_t job) const {
  Db& db = impl_->db;
  return impl_->read("frame_keys", [&] {
    job_info(db, job);
    Statement st(db, "SELECT level, frame FROM frames WHERE job_id = ?1 ORDER BY level, frame");
    st.bind_all(job);
    std::vector<FrameKey> keys;
    while (st.step()) keys.push_back(FrameKey{st.column_int(0), st.column_int(1)});
    return keys;
  });
}

bool TaskStore::frame_stored(int64_t job, const FrameKey& key) const {
  Db& db = impl_->db;
  return impl_->read("frame_stored", [&] {
    check_frame(db, "frame_stored", job, job_info(db, job), key);
    Statement st(db, "SELECT 1 FROM frames WHERE job_id = ?1 AND level = ?2 AND frame = ?3");
    return st.bind_all(job, key.level, key.frame).step();
  });
}

std::optional<double> TaskStore::frame_kappa(int64_t job, const FrameKey& key) const {
  Db& db = impl_->db;
  return impl_->read("frame_kappa", [&] {
    check_frame(db, "frame_kappa", job, job_info(db, job), key);
    Statement st(db, "SELECT kappa FROM frames WHERE job_id = ?1 AND level = ?2 AND frame = ?3");
    return st.bind_all(job, key.level, key.frame).step() ? st.column_optional_double(0) : std::nullopt;
  });
}

std::vector<int> TaskStore::frames_stored(int64_t job) const {
  Db& db = impl_->db;
  return impl_->read("frames_stored", [&] {
    const JobInfo info = job_info(db, job);
    std::vector<int> counts(static_cast<size_t>(info.levels), 0);
    Statement st(db, "SELECT level, COUNT(*) FROM frames WHERE job_id = ?1 GROUP BY level ORDER BY level");
    st.bind_all(job);
    while (st.step()) {
      const int level = st.column_int(0);
      if (level < 0 || level >= info.levels) db.fail_with("job " + str(job) + ": stored frame of level " + str(level));
      counts[static_cast<size_t>(level)] = st.column_int(1);
    }
    return counts;
  });
}

std::vector<int> TaskStore::stored_frames(int64_t job, int level, int first, int last) const {
  Db& db = impl_->db;
  return impl_->read("stored_frames", [&] { return frames_between(db, "stored_frames", "frames", job, level, first, last); });
}

void TaskStore::record_guide_frame(int64_t job, const FrameKey& key, const std::vector<double>& positions) {
  Db& db = impl_->db;
  impl_->write("record_guide_frame", [&] {
    check_frame(db, "record_guide_frame", job, job_info(db, job), key);
    run_sql(db, "INSERT INTO guide_frames(job_id, level, frame, positions) VALUES(?1, ?2, ?3, ?4) "
            "ON CONFLICT(job_id, level, frame) DO UPDATE SET positions = excluded.positions",
            job, key.level, key.frame, doubles_blob(positions));
    promote(db, job);
  });
}

std::optional<std::vector<double>> TaskStore::guide_frame(int64_t job, const FrameKey& key) const {
  Db& db = impl_->db;
  return impl_->read("guide_frame", [&]() -> std::optional<std::vector<double>> {
    check_frame(db, "guide_frame", job, job_info(db, job), key);
    Statement st(db, "SELECT positions FROM guide_frames WHERE job_id = ?1 AND level = ?2 AND frame = ?3");
    if (!st.bind_all(job, key.level, key.frame).step()) return std::nullopt;
    return blob_doubles(db, st.column_blob(0), "positions");
  });
}

std::vector<int> TaskStore::stored_guide_frames(int64_t job, int level, int first, int last) const {
  Db& db = impl_->db;
  return impl_->read("stored_guide_frames", [&] {
    return frames_between(db, "stored_guide_frames", "guide_frames", job, level, first, last);
  });
}

}  // namespace pd
