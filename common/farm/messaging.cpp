#include "farm/messaging.h"

#include <cerrno>
#include <iterator>
#include <vector>

#include <zmq_addon.hpp>

namespace pd::farm {

void configure_socket(zmq::socket_t& socket) {
  socket.set(zmq::sockopt::linger, 0);
  socket.set(zmq::sockopt::maxmsgsize, static_cast<int64_t>(protocol::kMaxMessageBytes));
}

std::string last_endpoint(const zmq::socket_t& socket) { return socket.get(zmq::sockopt::last_endpoint); }

void send_parts(zmq::socket_t& socket, const protocol::Parts& parts) {
  std::vector<zmq::const_buffer> buffers;
  buffers.reserve(parts.size());
  for (const std::string& p : parts) buffers.emplace_back(p.data(), p.size());
  zmq::send_multipart(socket, buffers);
}

bool send_parts_to(zmq::socket_t& socket, const std::string& identity, const protocol::Parts& parts) {
  std::vector<zmq::const_buffer> buffers;
  buffers.reserve(parts.size() + 1);
  buffers.emplace_back(identity.data(), identity.size());
  for (const std::string& p : parts) buffers.emplace_back(p.data(), p.size());
  // The high-water mark is checked on a message's first part, so a multipart message is queued whole
  // or not at all.
  return zmq::send_multipart(socket, buffers, zmq::send_flags::dontwait).has_value();
}

std::optional<protocol::Parts> recv_parts(zmq::socket_t& socket) {
  std::vector<zmq::message_t> messages;
  try {
    if (!zmq::recv_multipart(socket, std::back_inserter(messages))) return std::nullopt;
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return std::nullopt;
    throw;
  }
  protocol::Parts parts;
  parts.reserve(messages.size());
  for (const zmq::message_t& m : messages) parts.push_back(m.to_string());
  return parts;
}

std::optional<Routed> recv_routed(zmq::socket_t& socket) {
  std::optional<protocol::Parts> parts = recv_parts(socket);
  if (!parts || parts->empty()) return std::nullopt;
  Routed r;
  r.identity = std::move(parts->front());
  r.parts.assign(std::make_move_iterator(parts->begin() + 1), std::make_move_iterator(parts->end()));
  return r;
}

std::optional<protocol::Parts> recv_parts_within(zmq::socket_t& socket, std::chrono::milliseconds timeout) {
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= deadline) return std::nullopt;
    // Rounded up: a truncated 0 ms would return up to 1 ms before the deadline, which a caller
    // timing the wait (FarmClient: "interrupted" when it returns early) would misread.
    zmq::poll(&item, 1, std::chrono::ceil<std::chrono::milliseconds>(deadline - now));
    if (item.revents & ZMQ_POLLIN) return recv_parts(socket);
  }
}

bool is_loopback_endpoint(const std::string& endpoint) {
  if (endpoint.rfind("ipc://", 0) == 0 || endpoint.rfind("inproc://", 0) == 0) return true;
  const std::string tcp = "tcp://";
  if (endpoint.rfind(tcp, 0) != 0) return false;
  const std::string host = endpoint.substr(tcp.size(), endpoint.rfind(':') - tcp.size());
  return host.rfind("127.", 0) == 0 || host == "localhost" || host == "[::1]";
}

}  // namespace pd::farm
