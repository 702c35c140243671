#include "farm/messaging.h"

#include <gtest/gtest.h>

#include <chrono>

namespace pd::farm {
namespace {

using namespace std::chrono_literals;

TEST(Messaging, LoopbackEndpointsAreRecognisedAndOthersAreNot) {
  for (const char* e : {"tcp://127.0.0.1:7400", "tcp://127.3.2.1:1", "tcp://localhost:0", "tcp://[::1]:5",
                        "ipc:///tmp/pd.sock", "inproc://x"})
    EXPECT_TRUE(is_loopback_endpoint(e)) << e;
  for (const char* e : {"tcp://0.0.0.0:7400", "tcp://10.0.0.2:7400", "tcp://*:7400", "tcp://eth0:1",
                        "tcp://128.0.0.1:7400", "udp://127.0.0.1:1", "127.0.0.1:7400", ""})
    EXPECT_FALSE(is_loopback_endpoint(e)) << e;
}

TEST(Messaging, RouterAndDealerExchangePartsWithBinaryContentIntact) {
  zmq::context_t ctx(1);
  zmq::socket_t router(ctx, zmq::socket_type::router), dealer(ctx, zmq::socket_type::dealer);
  configure_socket(router);
  configure_socket(dealer);
  EXPECT_EQ(router.get(zmq::sockopt::linger), 0);
  router.bind("tcp://127.0.0.1:0");
  const std::string endpoint = last_endpoint(router);
  ASSERT_EQ(endpoint.rfind("tcp://127.0.0.1:", 0), 0u) << endpoint;
  EXPECT_NE(endpoint, "tcp://127.0.0.1:0");  // port 0 resolved to the bound port
  dealer.connect(endpoint);

  const protocol::Parts sent = {"{\"v\":1}", std::string("\0\x01\xff binary", 10), ""};
  send_parts(dealer, sent);
  zmq::pollitem_t item{router.handle(), 0, ZMQ_POLLIN, 0};
  ASSERT_EQ(zmq::poll(&item, 1, 5000ms), 1);
  std::optional<Routed> got = recv_routed(router);
  ASSERT_TRUE(got);
  EXPECT_FALSE(got->identity.empty());
  EXPECT_EQ(got->parts, sent);

  EXPECT_TRUE(send_parts_to(router, got->identity, {"reply", std::string(3, '\0')}));
  std::optional<protocol::Parts> reply = recv_parts_within(dealer, 5000ms);
  ASSERT_TRUE(reply);
  EXPECT_EQ(*reply, (protocol::Parts{"reply", std::string(3, '\0')}));
}

TEST(Messaging, ReceiveWithinGivesUpAfterItsTimeout) {
  zmq::context_t ctx(1);
  zmq::socket_t dealer(ctx, zmq::socket_type::dealer);
  configure_socket(dealer);
  dealer.connect("tcp://127.0.0.1:1");  // nothing listens there
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(recv_parts_within(dealer, 200ms));
  const auto waited = std::chrono::steady_clock::now() - t0;
  EXPECT_GE(waited, 190ms);
  EXPECT_LT(waited, 5000ms);
}

}  // namespace
}  // namespace pd::farm
