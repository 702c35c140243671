#include "farm/curve.h"

#include <sys/stat.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "farm/messaging.h"
#include "support/input_error_of.h"
#include "support/test_paths.h"

namespace pd::farm {
namespace {

using namespace std::chrono_literals;
using test::input_error_of;

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

TEST(Curve, GeneratedPairsAreDistinctAndRoundTripThroughTheirFiles) {
  ASSERT_TRUE(curve_available()) << "this libzmq has no CURVE (zmq_has(\"curve\") is false)";
  const std::string dir = test::scratch_dir("curve_files");
  const CurveKeyPair a = generate_key_pair(), b = generate_key_pair();
  EXPECT_EQ(a.public_key.size(), 40u);
  EXPECT_EQ(a.secret_key.size(), 40u);
  EXPECT_NE(a.public_key, b.public_key);
  EXPECT_NE(a.secret_key, b.secret_key);
  EXPECT_NE(a.public_key, a.secret_key);

  write_key_pair(dir + "/a", a);
  const CurveKeyPair read = read_key_pair(dir + "/a.key");
  EXPECT_EQ(read.public_key, a.public_key);
  EXPECT_EQ(read.secret_key, a.secret_key);
  EXPECT_EQ(read_public_key(dir + "/a.pub"), a.public_key);
  struct stat st {};
  ASSERT_EQ(stat((dir + "/a.key").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << "the secret key file must be readable by its owner only";

  // Never overwritten: neither file changes, and a prefix whose .pub alone exists writes nothing.
  EXPECT_EQ(input_error_of([&] { write_key_pair(dir + "/a", b); }),
            dir + "/a.key: exists; a key file is never overwritten (remove it first or choose another prefix)");
  EXPECT_EQ(read_key_pair(dir + "/a.key").secret_key, a.secret_key);
  write_text(dir + "/c.pub", "public " + b.public_key + "\n");
  EXPECT_NE(input_error_of([&] { write_key_pair(dir + "/c", a); }).find(dir + "/c.pub: exists"), std::string::npos);
  EXPECT_NE(stat((dir + "/c.key").c_str(), &st), 0) << "c.key was written although c.pub was refused";

  // An authorized-keys file: bare keys, "public" lines (appended .pub files), comments, blank lines.
  write_text(dir + "/authorized", "# workers\n" + a.public_key + "\n\n   # indented comment\r\npublic " + b.public_key +
                                      "\r\n" + read.public_key + "   # a again, with a comment\n");
  EXPECT_EQ(read_authorized_keys(dir + "/authorized"),
            (std::vector<std::string>{a.public_key, b.public_key, a.public_key}));

  // The client options: both or neither.
  EXPECT_FALSE(read_client_keys("", ""));
  const std::optional<CurveClientKeys> keys = read_client_keys(dir + "/c.pub", dir + "/a.key");
  ASSERT_TRUE(keys);
  EXPECT_EQ(keys->server_public_key, b.public_key);
  EXPECT_EQ(keys->own.secret_key, a.secret_key);
  EXPECT_EQ(input_error_of([&] { read_client_keys("", dir + "/a.key"); }),
            "--key " + dir + "/a.key: needs --server-key too (the scheduler's public key file, its .pub)");
  EXPECT_EQ(input_error_of([&] { read_client_keys(dir + "/c.pub", ""); }),
            "--server-key " + dir + "/c.pub: needs --key too (this peer's own key pair, from pd keys)");
}

// Each bad file is refused with a message naming the file, the line and the field.
TEST(Curve, BadKeyFilesAreRefusedNamingFileLineAndField) {
  const std::string dir = test::scratch_dir("curve_bad_files");
  const CurveKeyPair p = generate_key_pair(), q = generate_key_pair();
  using Reader = std::function<void(const std::string&)>;
  const Reader pair = [](const std::string& f) { read_key_pair(f); };
  const Reader pub = [](const std::string& f) { read_public_key(f); };
  const Reader authorized = [](const std::string& f) { read_authorized_keys(f); };
  struct Case {
    const char* what;
    Reader read;
    std::string text;
    std::string expected;  // after "<file>"
  };
  const std::string bad_char = p.secret_key.substr(0, 39) + "~";
  const std::vector<Case> cases = {
      {"no secret line", pair, "public " + p.public_key + "\n",
       ": no 'secret <z85>' line (a key pair file, as pd keys writes PREFIX.key, has 'public' and 'secret')"},
      {"short key", pair, "public abc\nsecret " + p.secret_key + "\n",
       ":1: public: expected 40 Z85 characters, got 3"},
      {"not Z85", pair, "# comment\npublic " + p.public_key + "\nsecret " + bad_char + "\n",
       ":3: secret: character 40 ('~') is not a Z85 character"},
      {"overflowing Z85", pair, "public " + std::string(40, '#') + "\n", ":1: public: not a valid Z85 encoding"},
      {"mixed pair", pair, "public " + p.public_key + "\nsecret " + q.secret_key + "\n",
       ":2: secret: does not belong to the public key of line 1 (a pair mixed from two files?)"},
      {"field twice", pair, "public " + p.public_key + "\npublic " + p.public_key + "\n",
       ":2: public: given twice (first on line 1)"},
      {"unknown field", pair, "pubic " + p.public_key + "\n",
       ":1: unknown field 'pubic' (a key file has 'public <z85>' and 'secret <z85>' lines)"},
      {"text after the key", pair, "public " + p.public_key + " extra\n",
       ":1: public: unexpected text after the key: 'extra'"},
      {"no key", pair, "\n\npublic\n", ":3: public: no key after the field name"},
      {"secret in a public-key file", pub, "public " + p.public_key + "\nsecret " + p.secret_key + "\n",
       ":2: secret: a public-key file holds no secret key; give the .pub file (a secret key belongs on its owner's "
       "machine only)"},
      {"empty public-key file", pub, "# nothing\n", ": no 'public <z85>' line (as pd keys writes PREFIX.pub)"},
      {"authorized: short key", authorized, p.public_key + "\nshort\n",
       ":2: key: expected 40 Z85 characters, got 5 (one client public key per line)"},
      {"authorized: text after the key", authorized, p.public_key + " worker-1\n",
       ":1: unexpected text after the key: 'worker-1' (a comment starts with '#')"},
      {"authorized: a secret", authorized, "secret " + p.secret_key + "\n",
       ":1: secret: an authorized-keys file lists public keys only"},
      {"authorized: no key", authorized, "# nobody yet\n\n", ": lists no key; no worker or client could connect"},
  };
  int checked = 0;
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const std::string file = dir + "/case" + std::to_string(k);
    write_text(file, cases[k].text);
    EXPECT_EQ(input_error_of([&] { cases[k].read(file); }), file + cases[k].expected) << cases[k].what;
    ++checked;
  }
  EXPECT_EQ(checked, 15);
  EXPECT_EQ(input_error_of([&] { read_key_pair(dir + "/missing.key"); }),
            dir + "/missing.key: cannot read: No such file or directory");
}

// Counts the handshake events of a monitored socket; the test thread reads them (check_event).
class HandshakeMonitor : public zmq::monitor_t {
 public:
  int succeeded = 0;
  std::vector<int> protocol_failures;  // event values: ZMQ_PROTOCOL_ERROR_*
  std::vector<int> auth_failures;      // event values: ZAP status codes

  void on_event_handshake_succeeded(const zmq_event_t&, const char*) override { ++succeeded; }
  void on_event_handshake_failed_protocol(const zmq_event_t& e, const char*) override {
    protocol_failures.push_back(e.value);
  }
  void on_event_handshake_failed_auth(const zmq_event_t& e, const char*) override { auth_failures.push_back(e.value); }

  // Handles events until `done()` holds, at most `timeout`; whether it held.
  bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!done()) {
      if (std::chrono::steady_clock::now() >= deadline) return false;
      check_event(20);
    }
    return true;
  }
};

bool contains(const std::vector<int>& v, int x) { return std::find(v.begin(), v.end(), x) != v.end(); }

zmq::socket_t dealer_to(zmq::context_t& ctx, const std::string& endpoint, const std::optional<CurveClientKeys>& keys) {
  zmq::socket_t d(ctx, zmq::socket_type::dealer);
  configure_socket(d);
  if (keys) apply_curve_client(d, *keys);
  d.connect(endpoint);
  return d;
}

TEST(Curve, OnlyADealerWithAnAuthorizedKeyAndTheRightServerKeyGetsAMessageThrough) {
  const CurveKeyPair server = generate_key_pair(), other_server = generate_key_pair();
  const CurveKeyPair admitted = generate_key_pair(), stranger = generate_key_pair();
  zmq::context_t ctx(1);
  ZapAuthenticator zap(ctx, {admitted.public_key});
  zmq::socket_t router(ctx, zmq::socket_type::router);
  configure_socket(router);
  apply_curve_server(router, server);
  router.bind("tcp://127.0.0.1:0");
  const std::string endpoint = last_endpoint(router);
  HandshakeMonitor monitor;
  monitor.init(router, "inproc://curve-test-monitor",
               ZMQ_EVENT_HANDSHAKE_SUCCEEDED | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL | ZMQ_EVENT_HANDSHAKE_FAILED_AUTH);

  // The admitted peer: a message each way.
  zmq::socket_t good = dealer_to(ctx, endpoint, CurveClientKeys{server.public_key, admitted});
  send_parts(good, {"from the admitted peer"});
  zmq::pollitem_t item{router.handle(), 0, ZMQ_POLLIN, 0};
  ASSERT_EQ(zmq::poll(&item, 1, 5000ms), 1) << "the authorized dealer's message did not arrive";
  std::optional<Routed> got = recv_routed(router);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->parts, protocol::Parts{"from the admitted peer"});
  EXPECT_TRUE(send_parts_to(router, got->identity, {"reply"}));
  EXPECT_EQ(recv_parts_within(good, 5000ms), protocol::Parts{"reply"});
  EXPECT_TRUE(monitor.wait_until([&] { return monitor.succeeded >= 1; }, 5000ms));
  EXPECT_GE(zap.accepted(), 1);
  EXPECT_EQ(zap.refused(), 0);

  // Each intruder in turn: its handshake is seen failing (so it did try), then nothing of it arrives.
  struct Intruder {
    const char* what;
    std::optional<CurveClientKeys> keys;
    const std::vector<int>* failures;  // where its failure shows
    int value;                         // and with which value
  };
  const std::vector<Intruder> intruders = {
      {"an unlisted key pair", CurveClientKeys{server.public_key, stranger}, &monitor.auth_failures, 400},
      {"the wrong server key", CurveClientKeys{other_server.public_key, admitted}, &monitor.protocol_failures,
       ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC},
      {"no CURVE at all", std::nullopt, &monitor.protocol_failures, ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH},
  };
  int refused_intruders = 0;
  for (const Intruder& in : intruders) {
    zmq::socket_t bad = dealer_to(ctx, endpoint, in.keys);
    send_parts(bad, {std::string("from ") + in.what});
    EXPECT_TRUE(monitor.wait_until([&] { return contains(*in.failures, in.value); }, 5000ms))
        << in.what << ": no handshake failure " << in.value << " seen";
    EXPECT_EQ(zmq::poll(&item, 1, 500ms), 0) << in.what << ": a message got through";
    EXPECT_FALSE(recv_parts_within(bad, 100ms)) << in.what;
    ++refused_intruders;
  }
  EXPECT_EQ(refused_intruders, 3);
  EXPECT_GT(zap.refused(), 0);  // the unlisted key was the ZAP handler's to refuse

  // The admitted peer still gets through afterwards.
  send_parts(good, {"again"});
  ASSERT_EQ(zmq::poll(&item, 1, 5000ms), 1);
  got = recv_routed(router);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->parts, protocol::Parts{"again"});
}

TEST(Curve, TheZapHandlerRefusesAnotherDomainAndAnotherMechanismAndIsOnePerContext) {
  const CurveKeyPair server = generate_key_pair(), client = generate_key_pair();
  zmq::context_t ctx(1);
  std::vector<ZapDecision> decisions;  // written by the handler's thread, read after it stopped
  std::optional<ZapAuthenticator> zap;
  zap.emplace(ctx, std::vector<std::string>{client.public_key}, kZapDomain,
              [&](const ZapDecision& d) { decisions.push_back(d); });
  EXPECT_THROW(ZapAuthenticator(ctx, {client.public_key}), std::runtime_error);

  // A CURVE router in another ZAP domain, and a plain (NULL mechanism) router in the farm's domain.
  zmq::socket_t curve_router(ctx, zmq::socket_type::router), plain_router(ctx, zmq::socket_type::router);
  configure_socket(curve_router);
  configure_socket(plain_router);
  apply_curve_server(curve_router, server, "elsewhere");
  plain_router.set(zmq::sockopt::zap_domain, kZapDomain);
  curve_router.bind("tcp://127.0.0.1:0");
  plain_router.bind("tcp://127.0.0.1:0");
  zmq::socket_t a = dealer_to(ctx, last_endpoint(curve_router), CurveClientKeys{server.public_key, client});
  zmq::socket_t b = dealer_to(ctx, last_endpoint(plain_router), std::nullopt);
  send_parts(a, {"a"});
  send_parts(b, {"b"});
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (zap->refused() < 2 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
  EXPECT_GE(zap->refused(), 2);
  EXPECT_EQ(zap->accepted(), 0);
  zmq::pollitem_t items[] = {{curve_router.handle(), 0, ZMQ_POLLIN, 0}, {plain_router.handle(), 0, ZMQ_POLLIN, 0}};
  EXPECT_EQ(zmq::poll(items, 2, 300ms), 0) << "a refused peer's message arrived";

  const auto t0 = std::chrono::steady_clock::now();
  a.close();
  b.close();
  curve_router.close();
  plain_router.close();
  zap.reset();  // stops the thread: `decisions` is ours from here
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s) << "stopping the ZAP handler took too long";
  int curve_seen = 0, null_seen = 0;
  for (const ZapDecision& d : decisions) {
    EXPECT_EQ(d.status, 400);
    EXPECT_EQ(d.address, "127.0.0.1");
    if (d.mechanism == "CURVE") {
      EXPECT_EQ(d.domain, "elsewhere");
      EXPECT_EQ(d.client_key, client.public_key);
      ++curve_seen;
    } else {
      EXPECT_EQ(d.mechanism, "NULL");
      EXPECT_EQ(d.domain, kZapDomain);
      ++null_seen;
    }
  }
  EXPECT_GE(curve_seen, 1);
  EXPECT_GE(null_seen, 1);
}

}  // namespace
}  // namespace pd::farm
