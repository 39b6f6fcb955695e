// The CAN layer: URIs, the UDP wire format, and the udp, virtual and socketcan backends.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/can/bus_uri.hpp"
#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/can/udp_frame.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::can {
namespace {

using namespace std::chrono_literals;

std::string error_of(const std::string& uri) {
  try {
    parse_bus_uri(uri);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

CanFrame data_frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, bool extended = false) {
  CanFrame f;
  f.id = id;
  f.extended = extended;
  f.length = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

// A free UDP port on loopback, found by binding port 0.
std::uint16_t free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  struct sockaddr_in a {};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
  socklen_t size = sizeof(a);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &size);
  ::close(fd);
  return ntohs(a.sin_port);
}

TEST(BusUri, ParsesEveryScheme) {
  const BusUri s = parse_bus_uri("socketcan:can0");
  EXPECT_EQ(s.scheme, BusUri::Scheme::kSocketCan);
  EXPECT_EQ(s.interface, "can0");
  const BusUri u = parse_bus_uri("udp:127.0.0.1:47000");
  EXPECT_EQ(u.scheme, BusUri::Scheme::kUdp);
  EXPECT_EQ(u.host, "127.0.0.1");
  EXPECT_EQ(u.port, 47000);
  const BusUri v = parse_bus_uri("virtual:legs");
  EXPECT_EQ(v.scheme, BusUri::Scheme::kVirtual);
  EXPECT_EQ(v.name, "legs");
}

TEST(BusUri, ErrorsNameTheWrongPart) {
  EXPECT_NE(error_of("can0").find("no scheme"), std::string::npos);
  EXPECT_NE(error_of("tcp:host:1").find("unknown scheme 'tcp'"), std::string::npos);
  EXPECT_NE(error_of("socketcan:").find("interface name is empty"), std::string::npos);
  EXPECT_NE(error_of("socketcan:averyveryverylongname0").find("longer than 15"), std::string::npos);
  EXPECT_NE(error_of("udp:localhost").find("missing ':PORT'"), std::string::npos);
  EXPECT_NE(error_of("udp::47000").find("host is empty"), std::string::npos);
  EXPECT_NE(error_of("udp:localhost:0").find("port '0' must be a number in 1..65535"), std::string::npos);
  EXPECT_NE(error_of("udp:localhost:65536").find("port '65536'"), std::string::npos);
  EXPECT_NE(error_of("udp:localhost:47x").find("port '47x'"), std::string::npos);
  EXPECT_NE(error_of("virtual:").find("bus name is empty"), std::string::npos);
  EXPECT_THROW(open_can_bus("bogus:x"), InputError);
}

TEST(UdpFrame, LayoutIsStructCanFrameWithABigEndianId) {
  std::array<std::uint8_t, kUdpFrameSize> bytes{};
  encode_udp_frame(data_frame(0x123, {0xDE, 0xAD}), bytes);
  const std::array<std::uint8_t, kUdpFrameSize> expected{0x00, 0x00, 0x01, 0x23, 2, 0, 0, 0, 0xDE, 0xAD, 0, 0, 0, 0, 0, 0};
  EXPECT_EQ(bytes, expected);

  encode_udp_frame(data_frame(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8}, true), bytes);
  EXPECT_EQ(bytes[0], 0x80 | 0x1A);  // EFF flag in bit 31
  EXPECT_EQ(bytes[3], 0xF0);
  EXPECT_EQ(bytes[4], 8);
  EXPECT_EQ(bytes[15], 8);
}

TEST(UdpFrame, RoundTripsDataRemoteAndErrorFrames) {
  CanFrame remote = data_frame(0x7FF, {});
  remote.remote = true;
  CanFrame error;
  error.error = true;
  error.id = 0x40;  // CAN_ERR_BUSOFF
  error.length = 8;
  for (const CanFrame& f : {data_frame(0, {}), data_frame(0x7FF, {1, 2, 3, 4, 5, 6, 7, 8}),
                            data_frame(0x1FFFFFFF, {9}, true), remote, error}) {
    std::array<std::uint8_t, kUdpFrameSize> bytes{};
    encode_udp_frame(f, bytes);
    const auto back = decode_udp_frame(bytes);
    ASSERT_TRUE(back.has_value()) << to_string(f);
    EXPECT_EQ(*back, f) << to_string(f);
  }
}

TEST(UdpFrame, RejectsLengthOverEightAndWideStandardIds) {
  std::array<std::uint8_t, kUdpFrameSize> bytes{};
  encode_udp_frame(data_frame(0x10, {1}), bytes);
  bytes[4] = 9;
  const char* why = nullptr;
  EXPECT_FALSE(decode_udp_frame(bytes, &why).has_value());
  EXPECT_STREQ(why, "data length over 8");
  bytes[4] = 1;
  bytes[2] = 0x08;  // id 0x810 without the EFF flag
  EXPECT_FALSE(decode_udp_frame(bytes, &why).has_value());
  EXPECT_STREQ(why, "standard frame with an id over 11 bits");
}

TEST(CanFrame, InvalidFramesAreNotSent) {
  auto a = open_can_bus("virtual:invalid");
  EXPECT_THROW(a->send(data_frame(0x800, {})), CanError);
  CanFrame long_frame = data_frame(1, {});
  long_frame.length = 9;
  EXPECT_THROW(a->send(long_frame), CanError);
  EXPECT_NO_THROW(a->send(data_frame(0x800, {}, true)));
}

TEST(VirtualBus, DeliversToOtherEndpointsOnly) {
  auto a = open_can_bus("virtual:deliver");
  auto b = open_can_bus("virtual:deliver");
  auto c = open_can_bus("virtual:elsewhere");
  a->send(data_frame(0x10, {1, 2}));
  CanFrame got;
  ASSERT_TRUE(b->receive(got, 100ms));
  EXPECT_EQ(got, data_frame(0x10, {1, 2}));
  EXPECT_FALSE(a->receive(got, 0ms)) << "an endpoint does not hear itself";
  EXPECT_FALSE(c->receive(got, 0ms)) << "another bus name is another bus";
}

TEST(VirtualBus, FiltersMatchIdMaskAndWidth) {
  auto a = open_can_bus("virtual:filters");
  auto b = open_can_bus("virtual:filters");
  const std::vector<CanFilter> filters{{0x100, 0x7F0, false}};  // 0x100..0x10F, standard only
  b->set_filters(filters);
  a->send(data_frame(0x10F, {1}));
  a->send(data_frame(0x110, {2}));
  a->send(data_frame(0x105, {3}, true));
  CanFrame got;
  ASSERT_TRUE(b->receive(got, 100ms));
  EXPECT_EQ(got.id, 0x10Fu);
  EXPECT_FALSE(b->receive(got, 10ms));
  EXPECT_EQ(b->counters().filtered_out, 2u);
}

TEST(VirtualBus, ErrorFramesOnlyWhenEnabled) {
  auto a = open_can_bus("virtual:errors");
  auto b = open_can_bus("virtual:errors");
  CanFrame error;
  error.error = true;
  error.id = 0x40;
  a->send(error);
  CanFrame got;
  EXPECT_FALSE(b->receive(got, 10ms));
  b->set_error_frames(true);
  a->send(error);
  ASSERT_TRUE(b->receive(got, 100ms));
  EXPECT_TRUE(got.error);
}

TEST(VirtualBus, ReceiveTimesOut) {
  auto a = open_can_bus("virtual:timeout");
  CanFrame got;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(a->receive(got, 30ms));
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_GE(waited, 29ms);
  EXPECT_LT(waited, 500ms);
}

TEST(UdpBus, ControllerAndDeviceTalkBothWays) {
  const std::string uri = "udp:127.0.0.1:" + std::to_string(free_udp_port());
  auto device = open_can_bus(uri, BusRole::kDevice);
  auto controller = open_can_bus(uri, BusRole::kController);
  controller->send(data_frame(0x001, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFC}));
  CanFrame got;
  ASSERT_TRUE(device->receive(got, 1s));
  EXPECT_EQ(got.data[7], 0xFC);
  device->send(data_frame(0x000, {1, 2, 3, 4, 5, 6}));  // answered to the controller's address
  ASSERT_TRUE(controller->receive(got, 1s));
  EXPECT_EQ(got, data_frame(0x000, {1, 2, 3, 4, 5, 6}));
}

TEST(UdpBus, BatchesArriveInOrderAcrossDatagrams) {
  const std::string uri = "udp:127.0.0.1:" + std::to_string(free_udp_port());
  auto device = open_can_bus(uri, BusRole::kDevice);
  auto controller = open_can_bus(uri, BusRole::kController);
  std::vector<CanFrame> frames;
  for (std::uint32_t i = 0; i < 40; ++i) frames.push_back(data_frame(i, {static_cast<std::uint8_t>(i)}));
  controller->send(frames);
  for (std::uint32_t i = 0; i < 40; ++i) {
    CanFrame got;
    ASSERT_TRUE(device->receive(got, 1s)) << i;
    EXPECT_EQ(got.id, i);
  }
  EXPECT_EQ(controller->counters().sent, 40u);
}

TEST(UdpBus, MalformedDatagramsAreDroppedAndCounted) {
  const std::uint16_t port = free_udp_port();
  auto device = open_can_bus("udp:127.0.0.1:" + std::to_string(port), BusRole::kDevice);
  const int raw = ::socket(AF_INET, SOCK_DGRAM, 0);
  struct sockaddr_in to {};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const std::uint8_t junk[10] = {1, 2, 3};
  ::sendto(raw, junk, sizeof(junk), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
  std::uint8_t bad_length[kUdpFrameSize] = {0, 0, 0, 1, 12};
  ::sendto(raw, bad_length, sizeof(bad_length), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
  ::close(raw);
  CanFrame got;
  EXPECT_FALSE(device->receive(got, 100ms));
  EXPECT_EQ(device->counters().malformed, 2u);
}

TEST(UdpBus, SendingToNobodyLosesFramesWithoutFailing) {
  auto controller = open_can_bus("udp:127.0.0.1:" + std::to_string(free_udp_port()));
  for (int i = 0; i < 5; ++i) EXPECT_NO_THROW(controller->send(data_frame(1, {1})));
  CanFrame got;
  EXPECT_NO_THROW(controller->receive(got, 20ms));
}

TEST(UdpBus, FiltersApplyInSoftware) {
  const std::string uri = "udp:127.0.0.1:" + std::to_string(free_udp_port());
  auto device = open_can_bus(uri, BusRole::kDevice);
  auto controller = open_can_bus(uri, BusRole::kController);
  const std::vector<CanFilter> only_0x20{{0x20, 0x7FF, false}};
  device->set_filters(only_0x20);
  controller->send(std::vector<CanFrame>{data_frame(0x21, {}), data_frame(0x20, {7})});
  CanFrame got;
  ASSERT_TRUE(device->receive(got, 1s));
  EXPECT_EQ(got.id, 0x20u);
  EXPECT_EQ(device->counters().filtered_out, 1u);
}

TEST(UdpBus, UnresolvableHostIsACanError) {
  EXPECT_THROW(open_can_bus("udp:no-such-host.invalid:47000"), CanError);
}

TEST(SocketCan, FailsWithAClearMessageWithoutTheInterfaceOrAfCan) {
  const int probe = ::socket(PF_CAN, SOCK_RAW, 1 /* CAN_RAW */);
  const bool kernel_has_can = probe >= 0;
  if (probe >= 0) ::close(probe);
  try {
    open_can_bus("socketcan:cpgmnosuch0");
    FAIL() << "opening a missing CAN interface must fail";
  } catch (const CanError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("socketcan:cpgmnosuch0: ", 0), 0u) << message;
    if (kernel_has_can) {
      EXPECT_NE(message.find("no network interface 'cpgmnosuch0'"), std::string::npos) << message;
    } else {
      EXPECT_NE(message.find("this kernel has no SocketCAN (AF_CAN)"), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace cpgmatch::can
