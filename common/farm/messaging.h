#pragma once
// ZeroMQ plumbing shared by pd-scheduler, pd-worker and the pd client: socket options every farm
// socket gets, and sending / receiving protocol::Parts (protocol/protocol.h) with and without the
// ROUTER's identity frame. Uses cppzmq's typed API only.
#include <chrono>
#include <optional>
#include <string>

#include <zmq.hpp>

#include "protocol/protocol.h"

namespace pd::farm {

// LINGER 0 (a closing socket drops what it has not sent instead of blocking the process) and
// MAXMSGSIZE protocol::kMaxMessageBytes (a larger incoming message drops the connection).
void configure_socket(zmq::socket_t& socket);

// The endpoint a socket bound to, e.g. "tcp://127.0.0.1:41234" after binding "tcp://127.0.0.1:0".
std::string last_endpoint(const zmq::socket_t& socket);

// Sends parts as one multipart message (blocking until queued).
void send_parts(zmq::socket_t& socket, const protocol::Parts& parts);
// ROUTER side: prefixes the peer's identity frame. Never blocks: returns false when the peer's
// queue is full (it has stopped reading: SNDHWM messages are waiting for it), so that one stuck
// peer cannot stall the scheduler's loop for everyone else. Throws zmq::error_t for an unknown
// peer on a ROUTER_MANDATORY socket (EHOSTUNREACH).
bool send_parts_to(zmq::socket_t& socket, const std::string& identity, const protocol::Parts& parts);

// Receives one whole multipart message (blocks). Returns nullopt only when interrupted (EINTR).
std::optional<protocol::Parts> recv_parts(zmq::socket_t& socket);

// A message received by a ROUTER: the sender's identity and the message's parts after it.
struct Routed {
  std::string identity;
  protocol::Parts parts;
};
// Receives one message on a ROUTER; nullopt when interrupted or when the message has no identity.
std::optional<Routed> recv_routed(zmq::socket_t& socket);

// Waits up to `timeout` for a message on `socket` (a DEALER or REQ), returns it or nullopt.
std::optional<protocol::Parts> recv_parts_within(zmq::socket_t& socket, std::chrono::milliseconds timeout);

// True for a tcp endpoint on the loopback range (127.0.0.0/8, localhost, [::1]) or an ipc/inproc one.
bool is_loopback_endpoint(const std::string& endpoint);

}  // namespace pd::farm
