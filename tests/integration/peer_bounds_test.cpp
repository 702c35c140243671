// What one peer can make the scheduler keep (issue 47 item 3), with a real farm on loopback and raw
// ZeroMQ peers that do what a pd client or pd-worker never would: a client pipelining hundreds of
// fetches without reading a reply (the scheduler keeps at most kClientReplyQueue replies queued to
// it), and a peer flooding the workers socket with malformed reports (every refusal is answered and
// logged, but only the first RefusalRows::kRowsPerPeer of a window become rows of farm.sqlite).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include <zmq.hpp>

#include "farm/messaging.h"
#include "protocol/protocol.h"
#include "store/task_store.h"
#include "support/farm.h"
#include "support/process.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using test::FarmTest;
using Clock = std::chrono::steady_clock;

// Events of `kind` in the scheduler's log so far.
int log_count(const test::Farm& farm, const std::string& kind) {
  return static_cast<int>(test::log_events(farm.scheduler_log(), kind).size());
}

bool wait_for_log(const test::Farm& farm, const std::string& kind, int count, std::chrono::seconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (log_count(farm, kind) < count) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(50ms);
  }
  return true;
}

// The scheduler's resident set, bytes.
double resident_bytes(pid_t pid) { return 1024.0 * static_cast<double>(test::proc_status_kib(pid, "VmRSS")); }

TEST_F(FarmTest, PipelinedFetchesHoldAFewRepliesAndAFloodOfRefusedReportsStoresTwentyRows) {
  test::Farm& farm = start_farm(1, "peer_bounds");
  const int64_t job = test::submit(farm, {test::scene_path("cube-trampoline.json"), "--frames", "60"});
  test::wait_until_done(farm, job, test::kShortJob);
  const double file_bytes = static_cast<double>(
      std::ifstream(farm.dir() + "/farm/jobs/" + std::to_string(job) + ".h5", std::ios::ate | std::ios::binary).tellg());
  ASSERT_GT(file_bytes, 1e5);
  const pid_t scheduler = farm.scheduler().pid();

  // 849 fetches of the whole job file, none read.
  zmq::context_t ctx(1);
  zmq::socket_t client(ctx, zmq::socket_type::dealer);
  farm::configure_socket(client);
  client.set(zmq::sockopt::sndtimeo, 5000);
  client.set(zmq::sockopt::rcvhwm, 1);  // read nothing, buffer little on this side
  client.connect(farm.clients());
  const double before = resident_bytes(scheduler);
  const int fetches_logged = log_count(farm, "job_fetched");
  for (int k = 0; k < 849; ++k) farm::send_parts(client, protocol::encode(protocol::FetchRequest{job}));
  ASSERT_TRUE(wait_for_log(farm, "job_fetched", fetches_logged + 849, 60s)) << "the fetches were not all served";
  const double grown = resident_bytes(scheduler) - before;
  std::printf("849 unread fetches of a %.2f MB job file: the scheduler grew %.1f MB, %d replies dropped\n",
              file_bytes / 1e6, grown / 1e6, log_count(farm, "reply_failed"));
  RecordProperty("unread_fetches_growth_mb", std::to_string(grown / 1e6));
  // At most kClientReplyQueue replies queued (and what the kernel's socket buffers took), against
  // 849 x the file before the bound (over 100 MB here).
  EXPECT_LT(grown, 16 * file_bytes + 32e6);
  EXPECT_GE(log_count(farm, "reply_failed"), 849 - 16 - 64);  // the kernel buffers may take a few replies
  // The farm keeps answering others.
  EXPECT_EQ(test::job_status(farm, job).at("state"), "done");

  // 2 000 malformed reports from one peer, each answered with Refused.
  zmq::socket_t peer(ctx, zmq::socket_type::dealer);
  farm::configure_socket(peer);
  peer.set(zmq::sockopt::rcvtimeo, 10000);
  peer.connect(farm.workers_endpoint());
  int answered = 0;
  for (int k = 0; k < 2000; ++k) {
    farm::send_parts(peer, {std::string("not json ") + std::to_string(k)});
    if (k % 50 == 49)  // read as it goes, so neither side's queue fills
      while (answered <= k && farm::recv_parts(peer)) ++answered;
  }
  while (answered < 2000 && farm::recv_parts(peer)) ++answered;
  EXPECT_EQ(answered, 2000);
  EXPECT_GE(log_count(farm, "report_refused"), 2000);  // every refusal is a log line
  const TaskStore store(farm.dir() + "/farm/farm.sqlite");
  int rows = 0;
  for (const EventRow& e : store.events(0)) rows += e.kind == "report_refused";
  std::printf("2 000 refused reports: %d log lines, %d rows in farm.sqlite\n", log_count(farm, "report_refused"), rows);
  EXPECT_EQ(rows, 20);
}

}  // namespace
}  // namespace pd
