#pragma once
// A DEALER spoken by hand over TCP (ZMTP 3.0, NULL mechanism; rfc.zeromq.org/spec/23), for what
// libzmq will not send: a frame header declaring more bytes than ZMQ_MAXMSGSIZE, a multipart message
// that never ends, bytes that are no frame at all (tests/integration/hostile_peers_test.cpp).
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/protocol.h"

namespace pd::test {

class RawZmtpPeer {
 public:
  // Connects to a tcp://host:port endpoint and (with `handshake`) does the handshake as a DEALER;
  // runtime_error naming the endpoint when the connection or the handshake fails within timeout_ms.
  RawZmtpPeer(const std::string& endpoint, int timeout_ms, bool handshake = true);
  ~RawZmtpPeer();
  RawZmtpPeer(const RawZmtpPeer&) = delete;
  RawZmtpPeer& operator=(const RawZmtpPeer&) = delete;

  // Bytes as they are (no framing).
  void send_raw(const std::string& bytes) { write_all(bytes); }
  // One message frame: `more` set when another frame of the same message follows.
  void send_frame(const std::string& body, bool more);
  // A long frame header declaring `size` bytes and nothing after it.
  void send_frame_header(uint64_t size, bool more);
  // Reads one whole message (frames up to one without MORE); nullopt after timeout_ms or when the
  // peer closed the connection.
  std::optional<protocol::Parts> recv_message(int timeout_ms);
  // True once the other end has closed the connection (read returns 0 or an error) within timeout_ms.
  bool closed_by_peer(int timeout_ms);

 private:
  void greet(int timeout_ms);  // greeting and READY, both ways
  void write_all(const std::string& bytes);
  bool read_exact(std::string& out, std::size_t n, int timeout_ms);

  int fd_ = -1;
  std::string endpoint_;
};

}  // namespace pd::test
