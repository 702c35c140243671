#pragma once
// The pd client's side of the farm protocol: one DEALER socket to the scheduler's client endpoint,
// one request and exactly one reply at a time (protocol/protocol.h, "Requests", "Replies").
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

#include <zmq.hpp>

#include "farm/curve.h"
#include "protocol/protocol.h"

namespace pd::cli {

// The scheduler's default client endpoint (its worker endpoint default is tcp://127.0.0.1:7400).
constexpr const char* kDefaultFarmEndpoint = "tcp://127.0.0.1:7401";

// The endpoint to talk to: `option` (--farm) when given, else the environment variable PD_FARM when
// set and non-empty, else kDefaultFarmEndpoint.
std::string farm_endpoint(const std::string& option);

// A blocking call was interrupted by a signal (EINTR), e.g. Ctrl-C while waiting for a reply, when
// the caller installed a handler; the caller decides whether to stop.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

class FarmClient {
 public:
  // Connects (lazily, as ZeroMQ does) a fresh DEALER socket to `endpoint`, a CURVE client with
  // `keys` when given (farm/curve.h). A malformed endpoint throws InputError naming it.
  explicit FarmClient(std::string endpoint, std::chrono::milliseconds timeout = std::chrono::seconds(5),
                      std::optional<farm::CurveClientKeys> keys = std::nullopt);

  // Sends `request` and waits up to the timeout for its reply. Throws InputError when
  //   no reply comes: "farm <endpoint>: no answer within 5 s (is pd-scheduler running? set --farm or PD_FARM)",
  //     with a word on keys when they may be why (a CURVE scheduler gives a peer it refuses nothing);
  //   the reply is an ErrorReply: its message, as the scheduler wrote it (e.g. "no job 17");
  //   the reply does not decode: "farm <endpoint>: bad reply: <ProtocolError>".
  // Throws Interrupted on EINTR. After a timeout or interruption the socket is replaced, so a late
  // reply to this request can never be taken for the reply to the next one.
  protocol::Reply request(const protocol::Request& request);

  // request(), then the reply as type T; another reply type throws InputError naming both.
  template <typename T>
  T request_as(const protocol::Request& r) {
    protocol::Reply reply = request(r);
    if (T* t = std::get_if<T>(&reply)) return std::move(*t);
    throw_unexpected(reply, r);
  }

  const std::string& endpoint() const { return endpoint_; }

 private:
  void connect();
  [[noreturn]] void throw_unexpected(const protocol::Reply& reply, const protocol::Request& request) const;

  std::string endpoint_;
  std::chrono::milliseconds timeout_;
  std::optional<farm::CurveClientKeys> keys_;
  zmq::context_t context_;
  zmq::socket_t socket_;
};

// The scene of a job, read for SubmitJob (farm/scene_source.h), with the checks pd simulate makes
// before it starts: a bad scene, and a `levels` override (>= 1; 0 = the scene's) that the scene's
// hierarchy settings cannot give, throw the InputError pd simulate --levels would give.
protocol::SceneSource read_job_scene(const std::string& path, int levels);

// True for the states a job does not leave (done, failed, cancelled).
bool job_finished(protocol::JobState state);

// Refuses (InputError naming `option`) an output path whose folder does not exist or that is a folder,
// before any work is done for it.
void check_output_path(const std::string& path, const std::string& option = "--out");

// Fetches the job file of `job` and writes it to `path`: to `path`.part first, then renamed, so a
// reader never sees half a file. Returns the number of bytes written.
std::size_t fetch_to_file(FarmClient& client, int64_t job, const std::string& path);

}  // namespace pd::cli
