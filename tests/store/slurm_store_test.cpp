#include "store/slurm_store.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "store/task_store.h"
#include "support/test_paths.h"

namespace pd {
namespace {

class SlurmStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("slurm_store");
    path_ = dir_ + "/farm.sqlite";
    tasks_ = std::make_unique<TaskStore>(path_);  // creates and checks the file, as the scheduler does
  }
  void TearDown() override {
    tasks_.reset();
    std::filesystem::remove_all(dir_);
  }
  std::string dir_, path_;
  std::unique_ptr<TaskStore> tasks_;
};

TEST_F(SlurmStoreTest, SubmittedTasksAreActiveUntilTheirStateIsAnEnd) {
  SlurmStore s(path_);
  s.add_submitted("40", {"40_0", "40_1"}, false, 100.0);
  ASSERT_EQ(s.active().size(), 2u);
  EXPECT_EQ(s.active()[0].state, "SUBMITTED");
  s.set_state("40_0", "RUNNING", "None", 101.0);
  s.set_state("40_1", "CANCELLED", "None", 102.0);
  ASSERT_EQ(s.active().size(), 1u);
  EXPECT_EQ(s.active()[0].id, "40_0");
  EXPECT_EQ(*s.find("40_1")->ended, 102.0);
  s.set_state("40_1", "GONE", "", 150.0);  // a later end keeps the first end time
  EXPECT_EQ(*s.find("40_1")->ended, 102.0);
  s.forget_ended_before(120.0);
  EXPECT_FALSE(s.find("40_1"));
  EXPECT_TRUE(s.find("40_0"));
}

TEST_F(SlurmStoreTest, AWorkersHelloLinksItsNameAndAHandSubmittedJobGetsARow) {
  SlurmStore s(path_);
  s.add_submitted("41", {"41_0"}, true, 10.0);
  s.link_worker("41_0", "slurm-41_0", 11.0);
  EXPECT_EQ(s.find("41_0")->state, "RUNNING");
  EXPECT_EQ(s.by_worker("slurm-41_0")->id, "41_0");
  EXPECT_TRUE(s.find("41_0")->replacement);
  s.link_worker("99_3", "by-hand", 12.0);  // sbatch run by a user, not by the scheduler
  EXPECT_EQ(s.find("99_3")->array_job, "99");
  EXPECT_EQ(s.find("99_3")->state, "RUNNING");
  EXPECT_TRUE(s.find("99_3")->external);
  EXPECT_FALSE(s.find("41_0")->external);
  EXPECT_FALSE(s.by_worker(""));
  ASSERT_EQ(s.rows().size(), 2u);
  EXPECT_EQ(s.rows()[0].id, "99_3");  // newest first
}

TEST_F(SlurmStoreTest, KeepTargetDrainingAndSettingsSurviveAReopen) {
  {
    SlurmStore s(path_);
    EXPECT_EQ(s.keep(), 0);
    s.set_keep(4);
    s.set_keep_request("{\"cpus\":2}");
    s.add_submitted("42", {"42_0"}, false, 5.0);
    s.set_draining("42_0", true);
  }
  SlurmStore again(path_);
  EXPECT_EQ(again.keep(), 4);
  EXPECT_EQ(again.keep_request(), "{\"cpus\":2}");
  EXPECT_TRUE(again.find("42_0")->draining);
  TaskStore reopened(path_);  // the task store still opens the file with the Slurm tables in it
}

}  // namespace
}  // namespace pd
