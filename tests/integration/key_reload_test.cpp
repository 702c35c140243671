// The scheduler's authorized keys reload on SIGHUP (docs/farm.md, "Authentication"; issue 47 item 4):
// a CURVE farm on loopback with real pd-scheduler and pd-worker processes. A worker whose key is not
// listed never registers; once its key is added to the file and the scheduler gets SIGHUP, it
// registers. A file broken by hand and reloaded keeps the keys in use; without CURVE, SIGHUP changes
// nothing and the scheduler keeps serving.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "farm/curve.h"
#include "support/farm.h"
#include "support/process.h"
#include "support/test_paths.h"

namespace pd {
namespace {

using namespace std::chrono_literals;
using test::Args;
using test::Farm;
using test::FarmOptions;

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << "cannot write " << path;
}

// Waits (bounded) for the scheduler's log to contain `text`.
bool log_shows(const Farm& farm, const std::string& text, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (test::read_file_text(farm.scheduler_log()).find(text) == std::string::npos) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(50ms);
  }
  return true;
}

// The names of the workers `pd workers --json` lists.
std::string listed_workers(const Farm& farm) {
  std::string names;
  const nlohmann::json listing = test::parse_json(farm.pd({"workers", "--json"}));  // kept: the loop reads into it
  for (const auto& w : listing.at("workers"))
    names += w.at("name").get<std::string>() + " ";
  return names;
}

class KeyReload : public test::FarmTest {};

TEST_F(KeyReload, AWorkerWhoseKeyIsAddedRegistersAfterSighupAndABrokenFileKeepsTheKeysInUse) {
  ASSERT_TRUE(farm::curve_available()) << "this libzmq has no CURVE";
  const std::string keys = test::scratch_dir("key_reload_keys");
  const char* names[] = {"server", "client", "admitted", "added"};
  for (const char* n : names) farm::write_key_pair(keys + "/" + n, farm::generate_key_pair());
  const auto pub = [&](const std::string& n) { return farm::read_key_pair(keys + "/" + n + ".key").public_key; };
  const std::string authorized = keys + "/authorized";
  write_text(authorized, pub("client") + "\n" + pub("admitted") + "\n");
  const auto worker_keys = [&](const std::string& n) -> Args {
    return {"--server-key", keys + "/server.pub", "--key", keys + "/" + n + ".key"};
  };

  FarmOptions options;
  options.workers = 0;
  options.scheduler_args = {"--key", keys + "/server.key", "--authorized-keys", authorized};
  options.client_args = {"--server-key", keys + "/server.pub", "--key", keys + "/client.key"};
  Farm& farm = start_farm(options, "key_reload");
  farm.add_worker(worker_keys("admitted"));
  farm.wait_for_idle_workers(1, 20s);

  // Not listed: refused at its handshake, so it never says hello.
  farm.add_worker(worker_keys("added"));
  ASSERT_TRUE(log_shows(farm, "auth_refused", 10s)) << test::read_file_text(farm.scheduler_log());
  EXPECT_EQ(listed_workers(farm), "w1 ");

  // Listed, then SIGHUP: the worker's next handshake is admitted (it reconnects on its own).
  write_text(authorized, pub("client") + "\n" + pub("admitted") + "\n" + pub("added") + "\n");
  ASSERT_EQ(kill(farm.scheduler().pid(), SIGHUP), 0);
  ASSERT_TRUE(log_shows(farm, "\"keys_reloaded\"", 10s)) << test::read_file_text(farm.scheduler_log());
  EXPECT_NE(test::read_file_text(farm.scheduler_log()).find(authorized + ": 3 key(s) admitted"), std::string::npos);
  farm.wait_for_idle_workers(2, 30s);

  // A file broken by hand: the reload is refused, naming the file and line, and the keys in use stay
  // (a new worker with the added key registers, the client still gets answers).
  write_text(authorized, pub("client") + "\nnot-a-key\n");
  ASSERT_EQ(kill(farm.scheduler().pid(), SIGHUP), 0);
  ASSERT_TRUE(log_shows(farm, "\"keys_reload_failed\"", 10s)) << test::read_file_text(farm.scheduler_log());
  EXPECT_NE(test::read_file_text(farm.scheduler_log()).find(authorized + ":2: key: expected 40 Z85 characters"),
            std::string::npos)
      << test::read_file_text(farm.scheduler_log());
  farm.add_worker(worker_keys("added"));
  farm.wait_for_idle_workers(3, 30s);
  EXPECT_EQ(listed_workers(farm), "w1 w2 w3 ");
}

TEST_F(KeyReload, SighupWithoutCurveIsLoggedAndChangesNothing) {
  Farm& farm = start_farm(1, "key_reload_none");
  ASSERT_EQ(kill(farm.scheduler().pid(), SIGHUP), 0);
  ASSERT_TRUE(log_shows(farm, "\"keys_reload_ignored\"", 10s)) << test::read_file_text(farm.scheduler_log());
  EXPECT_TRUE(farm.scheduler().running());
  EXPECT_EQ(listed_workers(farm), "w1 ");
}

}  // namespace
}  // namespace pd
