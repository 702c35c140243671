#pragma once
// ZeroMQ CURVE for the farm's sockets (RFC 26, CurveZMQ; RFC 27, ZAP): key files, the socket options
// of a CURVE server (pd-scheduler) and a CURVE client (pd-worker, pd), and a ZAP handler that admits
// only the client public keys of an authorized-keys file.
//
// Key files are text, one "FIELD Z85" pair per line, '#' starting a comment line:
//   PREFIX.key  "public <z85>" and "secret <z85>"   (a key pair; written with mode 0600)
//   PREFIX.pub  "public <z85>"                       (the public key alone; safe to copy around)
// where <z85> is a 32-byte Curve25519 key in Z85 text (40 characters, zmq_z85_encode).
// An authorized-keys file lists one client public key per line: "<z85>" or "public <z85>" (so a
// .pub file can be appended as it is), optionally followed by a '#' comment; blank lines and '#'
// comment lines are skipped. (Z85 has a '#' character, but no key starts with one: a 5-character
// group beginning with '#' exceeds 32 bits.)
//
// Every bad file is an InputError (util/input_error.h) whose message names the file and, where
// there is one, the line and field: "w1.key:3: secret: expected 40 Z85 characters, got 12".
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <zmq.hpp>

namespace pd::farm {

// Z85 text of a 32-byte key.
struct CurveKeyPair {
  std::string public_key;
  std::string secret_key;
};

// What a CURVE client (worker, pd) needs: the server's public key and its own pair.
struct CurveClientKeys {
  std::string server_public_key;
  CurveKeyPair own;
};

// True when this libzmq was built with CURVE (zmq_has("curve")).
bool curve_available();
// Throws InputError saying that this libzmq has no CURVE (and what to install) when it has none;
// `what` names the caller's option, e.g. "--key".
void require_curve(const std::string& what);

// A fresh key pair (zmq_curve_keypair).
CurveKeyPair generate_key_pair();

// Writes `pair` to PREFIX.key (both keys, mode 0600) and PREFIX.pub (the public key, mode 0644).
// Refuses (InputError naming it) to replace either file when it exists, so a secret key is never
// overwritten by accident; nothing is written then.
void write_key_pair(const std::string& prefix, const CurveKeyPair& pair);

// Reads a PREFIX.key file: both fields required, each once, and the secret must give the public
// key (zmq_curve_public), so a pair mixed up from two files is refused.
CurveKeyPair read_key_pair(const std::string& path);
// Reads the "public" line of a .pub file. A file holding a "secret" line is refused: a peer's public
// key is all another process needs, and a secret key copied where a public one belongs is a leak to
// fix (the message says so).
std::string read_public_key(const std::string& path);
// Reads an authorized-keys file (format above). A file that lists no key is refused: it would
// admit nobody.
std::vector<std::string> read_authorized_keys(const std::string& path);

// The keys of a worker's or client's --server-key FILE and --key FILE options: nullopt when both
// are empty, InputError when only one is given, a file is bad, or libzmq has no CURVE.
std::optional<CurveClientKeys> read_client_keys(const std::string& server_key_file, const std::string& key_file);

// The ZAP domain of the farm's CURVE server sockets.
constexpr const char* kZapDomain = "pd-farm";

// Server options, before bind: CURVE_SERVER 1, the server's secret key, and `zap_domain` so that
// every handshake is checked by the context's ZAP handler (ZapAuthenticator).
void apply_curve_server(zmq::socket_t& socket, const CurveKeyPair& own, const std::string& zap_domain = kZapDomain);
// Client options, before connect: the server's public key and the client's own pair.
void apply_curve_client(zmq::socket_t& socket, const CurveClientKeys& keys);

// One ZAP request and the answer given, for an observer (e.g. a log line).
struct ZapDecision {
  std::string domain;
  std::string address;     // the peer's IP address as libzmq gives it (no port)
  std::string mechanism;   // "CURVE" for the farm's sockets
  std::string client_key;  // Z85 of the client's public key; "" for another mechanism
  int status = 0;          // 200 accepted, 400 refused, 500 malformed request
};

// A ZAP handler (RFC 27) on `ctx`: a thread with a REP socket bound to inproc://zeromq.zap.01 that
// answers 200 to a CURVE handshake in `domain` whose client public key is in `authorized` (Z85
// text) and 400 to any other (another domain, another mechanism, an unlisted key); a malformed
// request gets 500. Bound by the time the constructor returns, so a socket bound afterwards never
// accepts a handshake unchecked. One per context (a second one throws std::runtime_error).
//
// Lifetime: destroy it after the CURVE sockets it guards are closed (while one is open and this is
// gone, libzmq lets its handshakes through: no handler bound means no ZAP check) and before `ctx`
// is terminated (zmq_ctx_term waits for this handler's socket). The destructor stops the thread at
// once (a message on an inproc pipe; a 200 ms poll bound backs it up) and closes its sockets with
// LINGER 0.
class ZapAuthenticator {
 public:
  using Observer = std::function<void(const ZapDecision&)>;

  // `observer`, when given, is called on the handler's thread for every request answered.
  ZapAuthenticator(zmq::context_t& ctx, const std::vector<std::string>& authorized, std::string domain = kZapDomain,
                   Observer observer = {});
  ~ZapAuthenticator();
  ZapAuthenticator(const ZapAuthenticator&) = delete;
  ZapAuthenticator& operator=(const ZapAuthenticator&) = delete;

  // Replaces the admitted keys (Z85, as the constructor's) for every handshake from now on: the
  // scheduler's key reload (SIGHUP). Peers already connected keep their sessions (CURVE
  // authenticates a connection once, at its handshake). Any thread.
  void set_authorized(const std::vector<std::string>& authorized);

  // Handshakes answered 200 and 400/500 so far.
  int64_t accepted() const { return accepted_.load(); }
  int64_t refused() const { return refused_.load(); }

 private:
  void serve();  // the thread's loop
  void answer(const std::vector<zmq::message_t>& request);

  mutable std::mutex authorized_mutex_;  // guards authorized_ (the handler thread reads, set_authorized writes)
  std::set<std::string> authorized_;     // 32-byte binary keys
  std::string domain_;
  Observer observer_;
  zmq::socket_t handler_;   // REP on inproc://zeromq.zap.01, used by the thread only
  zmq::socket_t stop_out_;  // PAIR, the destructor's end of the stop pipe
  zmq::socket_t stop_in_;   // PAIR, the thread's end
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> accepted_{0}, refused_{0};
  std::thread thread_;  // last: started once everything above exists
};

}  // namespace pd::farm
