// RawZmtpPeer (support/zmtp_peer.h): ZMTP 3.0 greeting, READY command and frames over a plain socket.
#include "support/zmtp_peer.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace pd::test {

using protocol::Parts;

namespace {

std::string big_endian(uint64_t x, int bytes) {
  std::string s(static_cast<std::size_t>(bytes), '\0');
  for (int k = bytes - 1; k >= 0; --k, x >>= 8) s[static_cast<std::size_t>(k)] = static_cast<char>(x & 0xff);
  return s;
}

uint64_t from_big_endian(const std::string& s) {
  uint64_t x = 0;
  for (char c : s) x = (x << 8) | static_cast<unsigned char>(c);
  return x;
}

// A ZMTP property: name length (1 byte), name, value length (4 bytes), value.
std::string property(const std::string& name, const std::string& value) {
  return std::string(1, static_cast<char>(name.size())) + name + big_endian(value.size(), 4) + value;
}

}  // namespace

RawZmtpPeer::RawZmtpPeer(const std::string& endpoint, int timeout_ms, bool handshake) : endpoint_(endpoint) {
  const std::string tcp = "tcp://";
  const std::size_t colon = endpoint.rfind(':');
  if (endpoint.rfind(tcp, 0) != 0 || colon == std::string::npos || colon < tcp.size())
    throw std::runtime_error(endpoint + ": not a tcp://host:port endpoint");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(std::stoi(endpoint.substr(colon + 1))));
  if (inet_pton(AF_INET, endpoint.substr(tcp.size(), colon - tcp.size()).c_str(), &addr.sin_addr) != 1)
    throw std::runtime_error(endpoint + ": not an IPv4 address");
  fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd_ < 0) throw std::runtime_error(endpoint + ": socket: " + std::strerror(errno));
  timeval tv{timeout_ms / 1000, (timeout_ms % 1000) * 1000};
  setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);  // a peer that stops reading cannot hang the test
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error(endpoint + ": connect: " + why);
  }
  if (!handshake) return;
  try {
    greet(timeout_ms);
  } catch (...) {
    ::close(fd_);  // the destructor does not run for a constructor that throws
    throw;
  }
}

void RawZmtpPeer::greet(int timeout_ms) {
  // Greeting: signature, version 3.0, mechanism NULL, as-server 0, filler.
  std::string greeting(64, '\0');
  greeting[0] = '\xff';
  greeting[9] = '\x7f';
  greeting[10] = 3;
  greeting.replace(12, 4, "NULL");
  write_all(greeting);
  const std::string ready = std::string("\x05READY") + property("Socket-Type", "DEALER") + property("Identity", "");
  write_all(std::string(1, '\x04') + static_cast<char>(ready.size()) + ready);
  std::string theirs;
  if (!read_exact(theirs, 64, timeout_ms) || theirs[0] != '\xff' || theirs[9] != '\x7f' || theirs[10] < 3)
    throw std::runtime_error(endpoint_ + ": no ZMTP 3 greeting from the peer");
  std::string flags, size, body;
  if (!read_exact(flags, 1, timeout_ms) || !(flags[0] & 0x04) ||
      !read_exact(size, (flags[0] & 0x02) ? 8 : 1, timeout_ms) ||
      !read_exact(body, from_big_endian(size), timeout_ms) || body.compare(0, 6, "\x05READY") != 0)
    throw std::runtime_error(endpoint_ + ": no READY command from the peer");
}

RawZmtpPeer::~RawZmtpPeer() {
  if (fd_ >= 0) ::close(fd_);
}

void RawZmtpPeer::write_all(const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(endpoint_ + ": send: " + std::strerror(errno));
    done += static_cast<std::size_t>(n);
  }
}

bool RawZmtpPeer::read_exact(std::string& out, std::size_t n, int timeout_ms) {
  out.assign(n, '\0');
  std::size_t got = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (got < n) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
    const ssize_t r = ::recv(fd_, out.data() + got, n - got, 0);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    got += static_cast<std::size_t>(r);
  }
  return true;
}

void RawZmtpPeer::send_frame(const std::string& body, bool more) {
  const bool long_frame = body.size() > 255;
  const char flags = static_cast<char>((more ? 0x01 : 0) | (long_frame ? 0x02 : 0));
  write_all(std::string(1, flags) + big_endian(body.size(), long_frame ? 8 : 1) + body);
}

void RawZmtpPeer::send_frame_header(uint64_t size, bool more) {
  write_all(std::string(1, static_cast<char>((more ? 0x01 : 0) | 0x02)) + big_endian(size, 8));
}

std::optional<Parts> RawZmtpPeer::recv_message(int timeout_ms) {
  Parts parts;
  for (;;) {
    std::string flags, size, body;
    if (!read_exact(flags, 1, timeout_ms) || !read_exact(size, (flags[0] & 0x02) ? 8 : 1, timeout_ms))
      return std::nullopt;
    const uint64_t n = from_big_endian(size);
    if (n > protocol::kMaxMessageBytes || !read_exact(body, n, timeout_ms)) return std::nullopt;
    if (flags[0] & 0x04) continue;  // a command (PING, ...), not a message frame
    parts.push_back(std::move(body));
    if (!(flags[0] & 0x01)) return parts;
  }
}

bool RawZmtpPeer::closed_by_peer(int timeout_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char buf[4096];
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
    const ssize_t r = ::recv(fd_, buf, sizeof buf, 0);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return true;  // 0: orderly close; < 0: reset
  }
}

}  // namespace pd::test
