#include "farm/curve.h"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>

#include <zmq_addon.hpp>

#include "util/input_error.h"

namespace pd::farm {
namespace {

constexpr std::size_t kKeyBytes = 32;
constexpr std::size_t kZ85Chars = 40;  // Z85: 5 characters per 4 bytes
constexpr const char* kZ85Alphabet =
    "0123456789abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ.-:+=^!/*?&<>()[]{}@%$#";
constexpr const char* kZapEndpoint = "inproc://zeromq.zap.01";  // fixed by RFC 27

// "" when `text` is a Z85 key, else what is wrong with it.
std::string z85_problem(const std::string& text) {
  if (text.size() != kZ85Chars)
    return "expected " + std::to_string(kZ85Chars) + " Z85 characters, got " + std::to_string(text.size());
  const std::size_t bad = text.find_first_not_of(kZ85Alphabet);
  if (bad != std::string::npos)
    return "character " + std::to_string(bad + 1) + " ('" + text.substr(bad, 1) + "') is not a Z85 character";
  std::array<uint8_t, kKeyBytes> bytes{};
  // Every character valid can still overflow a 4-byte group ("#####" > 2^32 - 1).
  if (zmq_z85_decode(bytes.data(), text.c_str()) == nullptr) return "not a valid Z85 encoding";
  return "";
}

// The 32 bytes of a Z85 key that z85_problem() accepted.
std::string binary_key(const std::string& z85) {
  if (!z85_problem(z85).empty()) throw std::invalid_argument("not a Z85 CURVE key: '" + z85 + "'");
  std::string bytes(kKeyBytes, '\0');
  zmq_z85_decode(reinterpret_cast<uint8_t*>(bytes.data()), z85.c_str());
  return bytes;
}

std::string z85_of(const std::string& bytes) {
  char text[kZ85Chars + 1] = {};
  zmq_z85_encode(text, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  return text;
}

std::vector<std::string> words_of(const std::string& line) {
  std::istringstream in(line);  // '\r' of a CRLF file is whitespace too
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

std::vector<std::string> lines_of(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot read: " + std::strerror(errno));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// A key file's fields ("public", "secret") and the line each came from, every value checked as Z85.
struct KeyFields {
  std::map<std::string, std::pair<std::string, int>> values;  // field -> (Z85, line)
};

KeyFields read_key_fields(const std::string& path) {
  KeyFields f;
  const std::vector<std::string> lines = lines_of(path);
  for (std::size_t k = 0; k < lines.size(); ++k) {
    const std::vector<std::string> w = words_of(lines[k]);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string at = path + ":" + std::to_string(k + 1) + ": ";
    if (w[0] != "public" && w[0] != "secret")
      throw InputError(at + "unknown field '" + w[0] + "' (a key file has 'public <z85>' and 'secret <z85>' lines)");
    if (w.size() < 2) throw InputError(at + w[0] + ": no key after the field name");
    if (w.size() > 2) throw InputError(at + w[0] + ": unexpected text after the key: '" + w[2] + "'");
    if (const std::string problem = z85_problem(w[1]); !problem.empty()) throw InputError(at + w[0] + ": " + problem);
    const auto seen = f.values.find(w[0]);
    if (seen != f.values.end())
      throw InputError(at + w[0] + ": given twice (first on line " + std::to_string(seen->second.second) + ")");
    f.values[w[0]] = {w[1], static_cast<int>(k + 1)};
  }
  return f;
}

// Creates `path` (refusing an existing one) with `mode` and writes `text` to it.
void write_new_file(const std::string& path, const std::string& text, mode_t mode) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) throw InputError(path + ": cannot create: " + std::strerror(errno));
  const ssize_t written = ::write(fd, text.data(), text.size());
  const int write_errno = errno;
  const bool closed = ::close(fd) == 0;
  if (written != static_cast<ssize_t>(text.size()) || !closed) {
    ::unlink(path.c_str());
    throw InputError(path + ": cannot write: " + std::strerror(written < 0 ? write_errno : EIO));
  }
}

}  // namespace

bool curve_available() { return zmq_has("curve") != 0; }

void require_curve(const std::string& what) {
  if (curve_available()) return;
  throw InputError(what + ": this libzmq has no CURVE support (zmq_has(\"curve\") is false); it needs a libzmq "
                   "built with libsodium, as Debian's libzmq5 is");
}

CurveKeyPair generate_key_pair() {
  require_curve("generating a CURVE key pair");
  char public_key[kZ85Chars + 1] = {}, secret_key[kZ85Chars + 1] = {};
  if (zmq_curve_keypair(public_key, secret_key) != 0)
    throw std::runtime_error(std::string("zmq_curve_keypair: ") + zmq_strerror(zmq_errno()));
  return {public_key, secret_key};
}

void write_key_pair(const std::string& prefix, const CurveKeyPair& pair) {
  const std::string key = prefix + ".key", pub = prefix + ".pub";
  for (const std::string& path : {key, pub}) {
    struct stat st;
    if (::lstat(path.c_str(), &st) == 0)
      throw InputError(path + ": exists; a key file is never overwritten (remove it first or choose another prefix)");
  }
  write_new_file(key,
                 "# pd CURVE key pair (pd keys, pd-scheduler --generate-keys): keep this file private\npublic " +
                     pair.public_key + "\nsecret " + pair.secret_key + "\n",
                 0600);
  try {
    write_new_file(pub, "# pd CURVE public key: give it to the peers that connect to, or admit, this key's owner\n"
                        "public " + pair.public_key + "\n",
                   0644);
  } catch (const InputError&) {
    ::unlink(key.c_str());  // all or nothing
    throw;
  }
}

CurveKeyPair read_key_pair(const std::string& path) {
  const KeyFields f = read_key_fields(path);
  for (const char* field : {"public", "secret"}) {
    if (f.values.count(field) == 0)
      throw InputError(path + ": no '" + field + " <z85>' line (a key pair file, as pd keys writes PREFIX.key, has " +
                       "'public' and 'secret')");
  }
  CurveKeyPair pair{f.values.at("public").first, f.values.at("secret").first};
  if (curve_available()) {
    char derived[kZ85Chars + 1] = {};
    if (zmq_curve_public(derived, pair.secret_key.c_str()) != 0 || pair.public_key != derived) {
      throw InputError(path + ":" + std::to_string(f.values.at("secret").second) +
                       ": secret: does not belong to the public key of line " +
                       std::to_string(f.values.at("public").second) + " (a pair mixed from two files?)");
    }
  }
  return pair;
}

std::string read_public_key(const std::string& path) {
  const KeyFields f = read_key_fields(path);
  if (const auto secret = f.values.find("secret"); secret != f.values.end()) {
    throw InputError(path + ":" + std::to_string(secret->second.second) +
                     ": secret: a public-key file holds no secret key; give the .pub file (a secret key belongs "
                     "on its owner's machine only)");
  }
  const auto pub = f.values.find("public");
  if (pub == f.values.end()) throw InputError(path + ": no 'public <z85>' line (as pd keys writes PREFIX.pub)");
  return pub->second.first;
}

std::vector<std::string> read_authorized_keys(const std::string& path) {
  std::vector<std::string> keys;
  const std::vector<std::string> lines = lines_of(path);
  for (std::size_t k = 0; k < lines.size(); ++k) {
    const std::vector<std::string> w = words_of(lines[k]);
    if (w.empty() || w[0][0] == '#') continue;  // blank, or a comment (no Z85 key starts with '#')
    const std::string at = path + ":" + std::to_string(k + 1) + ": ";
    if (w[0] == "secret") throw InputError(at + "secret: an authorized-keys file lists public keys only");
    const std::size_t key = w[0] == "public" ? 1 : 0;  // "public <z85>", as in a .pub file
    if (key >= w.size()) throw InputError(at + "public: no key after the field name");
    if (const std::string problem = z85_problem(w[key]); !problem.empty())
      throw InputError(at + "key: " + problem + " (one client public key per line)");
    if (key + 1 < w.size() && w[key + 1][0] != '#')
      throw InputError(at + "unexpected text after the key: '" + w[key + 1] + "' (a comment starts with '#')");
    keys.push_back(w[key]);
  }
  if (keys.empty()) throw InputError(path + ": lists no key; no worker or client could connect");
  return keys;
}

std::optional<CurveClientKeys> read_client_keys(const std::string& server_key_file, const std::string& key_file) {
  if (server_key_file.empty() && key_file.empty()) return std::nullopt;
  if (server_key_file.empty())
    throw InputError("--key " + key_file + ": needs --server-key too (the scheduler's public key file, its .pub)");
  if (key_file.empty())
    throw InputError("--server-key " + server_key_file + ": needs --key too (this peer's own key pair, from pd keys)");
  require_curve("--server-key/--key");
  CurveClientKeys keys;
  keys.server_public_key = read_public_key(server_key_file);
  keys.own = read_key_pair(key_file);
  return keys;
}

void apply_curve_server(zmq::socket_t& socket, const CurveKeyPair& own, const std::string& zap_domain) {
  require_curve("CURVE server");
  socket.set(zmq::sockopt::curve_server, true);
  socket.set(zmq::sockopt::curve_secretkey, binary_key(own.secret_key));
  socket.set(zmq::sockopt::zap_domain, zap_domain);
}

void apply_curve_client(zmq::socket_t& socket, const CurveClientKeys& keys) {
  require_curve("CURVE client");
  socket.set(zmq::sockopt::curve_serverkey, binary_key(keys.server_public_key));
  socket.set(zmq::sockopt::curve_publickey, binary_key(keys.own.public_key));
  socket.set(zmq::sockopt::curve_secretkey, binary_key(keys.own.secret_key));
}

// ---------------------------------------------------------------------------------------------------
// ZapAuthenticator

ZapAuthenticator::ZapAuthenticator(zmq::context_t& ctx, const std::vector<std::string>& authorized,
                                   std::string domain, Observer observer)
    : domain_(std::move(domain)),
      observer_(std::move(observer)),
      handler_(ctx, zmq::socket_type::rep),
      stop_out_(ctx, zmq::socket_type::pair),
      stop_in_(ctx, zmq::socket_type::pair) {
  for (const std::string& k : authorized) authorized_.insert(binary_key(k));
  for (zmq::socket_t* s : {&handler_, &stop_out_, &stop_in_}) s->set(zmq::sockopt::linger, 0);
  try {
    handler_.bind(kZapEndpoint);
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(std::string("ZAP handler: cannot bind ") + kZapEndpoint + ": " + e.what() +
                             " (one handler per ZeroMQ context)");
  }
  char stop_endpoint[64];
  std::snprintf(stop_endpoint, sizeof stop_endpoint, "inproc://pd-zap-stop-%p", static_cast<void*>(this));
  stop_out_.bind(stop_endpoint);
  stop_in_.connect(stop_endpoint);
  thread_ = std::thread([this] { serve(); });
}

ZapAuthenticator::~ZapAuthenticator() {
  stop_ = true;
  try {
    stop_out_.send(zmq::str_buffer("stop"), zmq::send_flags::dontwait);
  } catch (const zmq::error_t&) {
    // the thread still sees stop_ within its 200 ms poll
  }
  if (thread_.joinable()) thread_.join();
  // The sockets close as members, after the join (a socket may change threads after a full barrier).
}

void ZapAuthenticator::serve() {
  // Signals (SIGTERM, SIGINT) go to the process's other threads, whose loops watch for them.
  sigset_t all;
  sigfillset(&all);
  pthread_sigmask(SIG_BLOCK, &all, nullptr);
  zmq::pollitem_t items[] = {{handler_.handle(), 0, ZMQ_POLLIN, 0}, {stop_in_.handle(), 0, ZMQ_POLLIN, 0}};
  while (!stop_) {
    try {
      zmq::poll(items, 2, std::chrono::milliseconds(200));
      if (items[1].revents & ZMQ_POLLIN) break;
      if (!(items[0].revents & ZMQ_POLLIN)) continue;
      std::vector<zmq::message_t> request;
      if (!zmq::recv_multipart(handler_, std::back_inserter(request), zmq::recv_flags::dontwait)) continue;
      answer(request);
    } catch (const zmq::error_t& e) {
      if (e.num() == EINTR) continue;
      if (e.num() == ETERM) break;  // the context is being terminated
      // Anything else leaves the REP socket in an unknown state. Handshakes wait for an answer from
      // now on rather than pass unchecked: failing closed.
      std::fprintf(stderr, "ZAP handler stopped: %s; CURVE handshakes are no longer answered\n", e.what());
      break;
    }
  }
}

void ZapAuthenticator::set_authorized(const std::vector<std::string>& authorized) {
  std::set<std::string> keys;
  for (const std::string& k : authorized) keys.insert(binary_key(k));  // throws before anything changes
  const std::lock_guard<std::mutex> lock(authorized_mutex_);
  authorized_ = std::move(keys);
}

void ZapAuthenticator::answer(const std::vector<zmq::message_t>& request) {
  ZapDecision d;
  std::string request_id, text;
  if (request.size() >= 2) request_id = request[1].to_string();
  if (request.size() < 6 || request[0].to_string() != "1.0") {
    d.status = 500;
    text = "malformed ZAP request";
  } else {
    d.domain = request[2].to_string();
    d.address = request[3].to_string();
    d.mechanism = request[5].to_string();
    const bool curve = d.mechanism == "CURVE" && request.size() >= 7 && request[6].size() == kKeyBytes;
    const std::string key = curve ? request[6].to_string() : "";
    if (curve) d.client_key = z85_of(key);
    if (d.domain != domain_) {
      d.status = 400;
      text = "unknown ZAP domain";
    } else if (!curve) {
      d.status = 400;
      text = "only CURVE clients are admitted";
    } else if (const std::lock_guard<std::mutex> lock(authorized_mutex_); authorized_.count(key) == 0) {
      d.status = 400;
      text = "client key not authorized";
    } else {
      d.status = 200;
      text = "OK";
    }
  }
  // Counted before the answer leaves, so a peer that sees the outcome also sees it counted.
  (d.status == 200 ? accepted_ : refused_)++;
  const std::string status = std::to_string(d.status);
  const std::string user_id = d.status == 200 ? d.client_key : "";  // the User-Id of the peer's messages
  const std::array<zmq::const_buffer, 6> reply = {zmq::str_buffer("1.0"), zmq::buffer(request_id),
                                                  zmq::buffer(status),     zmq::buffer(text),
                                                  zmq::buffer(user_id),    zmq::str_buffer("")};
  zmq::send_multipart(handler_, reply);
  if (observer_) {
    try {
      observer_(d);
    } catch (const std::exception&) {
      // an observer (a log line) never stops the handler
    }
  }
}

}  // namespace pd::farm
