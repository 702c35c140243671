#include "scheduler/security.h"

#include <chrono>
#include <cstdio>
#include <set>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "farm/messaging.h"
#include "util/input_error.h"

namespace pd::scheduler {
namespace {

// Distinct (address, client key) refusals logged at most; a peer retrying with the same key (libzmq
// reconnects every 100 ms) is logged once, and a flood of random keys cannot grow the set forever.
constexpr std::size_t kMaxLoggedRefusals = 1000;

// The first refusal of each (address, key), as a line like the scheduler's own events
// (Scheduler::event; not stored in SQLite: the store is not for this thread).
farm::ZapAuthenticator::Observer refusal_logger() {
  auto seen = std::make_shared<std::set<std::pair<std::string, std::string>>>();
  return [seen](const farm::ZapDecision& d) {
    if (d.status == 200 || seen->size() >= kMaxLoggedRefusals) return;
    if (!seen->insert({d.address, d.client_key}).second) return;
    const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    std::string message = d.mechanism == "CURVE" ? "client key " + d.client_key + " is not in the authorized keys"
                                                 : "mechanism " + d.mechanism + " refused";
    message += " (from " + d.address + ", status " + std::to_string(d.status) + ")";
    if (seen->size() == kMaxLoggedRefusals) message += "; further refusals are not logged";
    const nlohmann::json line = {{"time", now}, {"event", "auth_refused"}, {"message", message}};
    std::fprintf(stderr, "%s\n", line.dump().c_str());
  };
}

}  // namespace

void check_security_options(const SchedulerOptions& options) {
  const bool key = !options.key_file.empty(), authorized = !options.authorized_keys_file.empty();
  if (key && !authorized)
    throw InputError("--key " + options.key_file +
                     ": needs --authorized-keys FILE too (the public keys of the workers and clients to admit)");
  if (authorized && !key)
    throw InputError("--authorized-keys " + options.authorized_keys_file +
                     ": needs --key FILE too (the scheduler's own key pair, from pd-scheduler --generate-keys)");
  if (!key) {
    for (const std::string* e : {&options.workers_endpoint, &options.clients_endpoint}) {
      if (!farm::is_loopback_endpoint(*e))
        throw InputError(*e + " is not a loopback address; binding beyond loopback needs --key and --authorized-keys "
                              "(CURVE; docs/farm.md, \"Authentication\")");
    }
    return;
  }
  farm::require_curve("--key");
  farm::read_key_pair(options.key_file);
  farm::read_authorized_keys(options.authorized_keys_file);
}

std::unique_ptr<farm::ZapAuthenticator> secure_sockets(zmq::context_t& ctx, const SchedulerOptions& options,
                                                       std::initializer_list<zmq::socket_t*> sockets) {
  check_security_options(options);
  if (options.key_file.empty()) return nullptr;
  const farm::CurveKeyPair own = farm::read_key_pair(options.key_file);
  auto zap = std::make_unique<farm::ZapAuthenticator>(ctx, farm::read_authorized_keys(options.authorized_keys_file),
                                                      farm::kZapDomain, refusal_logger());
  for (zmq::socket_t* s : sockets) farm::apply_curve_server(*s, own, farm::kZapDomain);
  return zap;
}

}  // namespace pd::scheduler
