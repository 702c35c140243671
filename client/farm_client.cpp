#include "farm_client.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>

#include "farm/messaging.h"
#include "farm/scene_source.h"
#include "hierarchy/scene_hierarchy.h"
#include "util/input_error.h"

namespace pd::cli {
namespace {

std::string seconds_text(std::chrono::milliseconds t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g s", static_cast<double>(t.count()) / 1000.0);
  return buf;
}

// The wire type name of a request or reply ("status", "error", ...), for messages.
template <typename Message>
std::string type_name(const Message& m) {
  try {
    return protocol::message_type(protocol::encode(m));
  } catch (const std::exception&) {
    return "(unknown)";
  }
}

}  // namespace

std::string farm_endpoint(const std::string& option) {
  if (!option.empty()) return option;
  const char* env = std::getenv("PD_FARM");
  if (env != nullptr && *env != '\0') return env;
  return kDefaultFarmEndpoint;
}

FarmClient::FarmClient(std::string endpoint, std::chrono::milliseconds timeout,
                       std::optional<farm::CurveClientKeys> keys)
    : endpoint_(std::move(endpoint)), timeout_(timeout), keys_(std::move(keys)), context_(1) {
  connect();
}

void FarmClient::connect() {
  socket_ = zmq::socket_t(context_, zmq::socket_type::dealer);
  farm::configure_socket(socket_);
  // A DEALER with no peer blocks on send; bound that by the same timeout as the reply.
  socket_.set(zmq::sockopt::sndtimeo, static_cast<int>(timeout_.count()));
  if (keys_) farm::apply_curve_client(socket_, *keys_);
  try {
    socket_.connect(endpoint_);
  } catch (const zmq::error_t& e) {
    throw InputError("farm endpoint \"" + endpoint_ + "\": " + e.what() +
                     " (expected e.g. tcp://127.0.0.1:7401; set --farm or PD_FARM)");
  }
}

protocol::Reply FarmClient::request(const protocol::Request& request) {
  // A CURVE scheduler answers a peer it refuses with nothing at all: say so where keys may be why.
  const std::string hint =
      keys_ ? "is pd-scheduler running, and does its --authorized-keys list this client's public key?"
            : (farm::is_loopback_endpoint(endpoint_)
                   ? "is pd-scheduler running?"
                   : "is pd-scheduler running? beyond loopback it answers only clients with --server-key and --key;");
  const std::string no_answer =
      "farm " + endpoint_ + ": no answer within " + seconds_text(timeout_) + " (" + hint + " set --farm or PD_FARM)";
  std::optional<protocol::Parts> parts;
  const auto start = std::chrono::steady_clock::now();
  try {
    farm::send_parts(socket_, protocol::encode(request));
    parts = farm::recv_parts_within(socket_, timeout_);
  } catch (const zmq::error_t& e) {
    connect();
    if (e.num() == EINTR) throw Interrupted();
    if (e.num() == EAGAIN) throw InputError(no_answer);  // the send itself timed out: nothing to talk to
    throw InputError("farm " + endpoint_ + ": " + e.what());
  }
  if (!parts) {
    // No message before the deadline, or a signal (recv_parts returns nullopt on EINTR): the
    // elapsed time tells them apart.
    const bool interrupted = std::chrono::steady_clock::now() - start < timeout_;
    connect();
    if (interrupted) throw Interrupted();
    throw InputError(no_answer);
  }
  protocol::Reply reply;
  try {
    reply = protocol::decode_reply(*parts);
  } catch (const protocol::ProtocolError& e) {
    throw InputError("farm " + endpoint_ + ": bad reply: " + e.what());
  }
  if (const auto* error = std::get_if<protocol::ErrorReply>(&reply)) throw InputError(error->message);
  return reply;
}

void FarmClient::throw_unexpected(const protocol::Reply& reply, const protocol::Request& request) const {
  throw InputError("farm " + endpoint_ + ": answered a '" + type_name(request) + "' request with a '" +
                   type_name(reply) + "' reply");
}

protocol::SceneSource read_job_scene(const std::string& path, int levels) {
  Scene scene;
  protocol::SceneSource source = farm::read_scene_source(path, &scene);
  // The hierarchy plan checks the level count against every object's hierarchy settings without
  // building anything; the worker would otherwise fail the job's first task with this same message.
  if (levels >= 1) scene.hierarchy.levels = levels;
  hierarchy_hash(scene);
  return source;
}

bool job_finished(protocol::JobState state) {
  return state == protocol::JobState::done || state == protocol::JobState::failed ||
         state == protocol::JobState::cancelled;
}

void check_output_path(const std::string& path, const std::string& option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty()) throw InputError(option + ": must name a file");
  if (fs::is_directory(path, ec)) throw InputError(option + " " + path + ": is a folder, not a file");
  fs::path folder = fs::path(path).parent_path();
  if (folder.empty()) folder = ".";
  if (!fs::is_directory(folder, ec))
    throw InputError(option + " " + path + ": folder " + folder.string() + " does not exist");
}

std::size_t fetch_to_file(FarmClient& client, int64_t job, const std::string& path) {
  namespace fs = std::filesystem;
  protocol::FetchReply reply = client.request_as<protocol::FetchReply>(protocol::FetchRequest{job});
  if (reply.job != job) {
    throw InputError("farm " + client.endpoint() + ": asked for job " + std::to_string(job) + ", got the file of job " +
                     std::to_string(reply.job));
  }
  const std::string part = path + ".part";
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot create " + part + ": " + std::strerror(errno));
    out.write(reply.blob.data(), static_cast<std::streamsize>(reply.blob.size()));
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(part, ec);
      throw InputError(path + ": cannot write " + part + " (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(part, path, ec);
  if (ec) {
    const std::string why = ec.message();
    fs::remove(part, ec);
    throw InputError(path + ": cannot rename " + part + " to it: " + why);
  }
  return reply.blob.size();
}

}  // namespace pd::cli
