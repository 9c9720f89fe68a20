// A phone replayed over loopback: a sender thread sends a synthetic imu.txt line by line at its
// recorded rate while the listener receives; every sample must arrive, parsed exactly.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "../unit/io_test_fixtures.hpp"
#include "imufusion/imu_stream.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

namespace imufusion {
namespace {

class UdpSender {
 public:
  explicit UdpSender(std::uint16_t port) : socket_(::socket(AF_INET, SOCK_DGRAM, 0)) {
    address_.sin_family = AF_INET;
    address_.sin_port = htons(port);
    ::inet_pton(AF_INET, "127.0.0.1", &address_.sin_addr);
  }
  ~UdpSender() { ::close(socket_); }
  bool send(const std::string& datagram) const {
    return ::sendto(socket_, datagram.data(), datagram.size(), 0,
                    reinterpret_cast<const sockaddr*>(&address_),
                    sizeof(address_)) == static_cast<ssize_t>(datagram.size());
  }

 private:
  int socket_;
  sockaddr_in address_{};
};

// imu.txt of a synthetic session (3 s of a 200 Hz phone IMU), written by SequenceWriter.
std::filesystem::path write_imu_txt(const testing::TempDir& dir, std::vector<ImuSample>* truth) {
  const synth::CameraMotion motion(synth::SceneKind::kRoom, 11, 100.0);
  *truth =
      synth::generate_imu(motion, synth::ImuConfig{}, synth::draw_imu_bias(11), 100.0, 103.0, 11);
  auto writer = SequenceWriter::create(dir / "seq");
  EXPECT_TRUE(writer.ok());
  DepthImage depth{4, 3, 5000.0, std::vector<std::uint16_t>(12, 1000)};
  EXPECT_TRUE(writer->add_depth(100.0, depth).ok());
  for (const ImuSample& sample : *truth) EXPECT_TRUE(writer->add_imu(sample).ok());
  EXPECT_TRUE(writer->finish().ok());
  return dir / "seq" / "imu.txt";
}

std::vector<ReceivedImuSample> receive(ImuUdpListener& listener, std::size_t expected) {
  std::vector<ReceivedImuSample> received;
  // A guard against a hang, not a speed requirement: the stream itself lasts 3 s.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (received.size() < expected && std::chrono::steady_clock::now() < give_up) {
    auto batch = listener.take_samples();  // as a scanner does once per frame
    received.insert(received.end(), batch.begin(), batch.end());
    std::this_thread::sleep_for(std::chrono::milliseconds(33));
  }
  return received;
}

TEST(ImuUdpLoopback, ReplaysASyntheticImuTxtAtItsRate) {
  testing::TempDir dir;
  std::vector<ImuSample> truth;
  const auto imu_txt = write_imu_txt(dir, &truth);
  std::vector<std::string> lines;
  {
    std::ifstream in(imu_txt);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }

  auto listener = ImuUdpListener::open({});
  ASSERT_TRUE(listener.ok()) << listener.error().describe();
  UdpSender sender(listener->port());
  std::size_t malformed_sent = 0, out_of_order_sent = 0;
  std::string first_garbage;
  std::thread phone([&] {
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < lines.size(); ++i) {
      if (lines[i].empty() || lines[i][0] == '#') {
        sender.send(lines[i]);  // comments are skipped silently
        continue;
      }
      const double t = std::stod(lines[i].substr(0, lines[i].find(' ')));
      std::this_thread::sleep_until(start +
                                    std::chrono::duration<double>(t - truth.front().timestamp));
      sender.send(lines[i]);
      if (i % 97 == 0) {  // interleave garbage and a stale sample
        const std::string garbage = "not an imu line " + std::to_string(i);
        if (first_garbage.empty()) first_garbage = garbage;
        sender.send(garbage);
        ++malformed_sent;
        sender.send(lines[i]);
        ++out_of_order_sent;
      }
    }
  });
  const auto received = receive(*listener, truth.size());
  phone.join();
  const ImuStreamStats stats = listener->stats();

  ASSERT_EQ(received.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    // imu.txt holds the shortest exact decimal of each double: bit-exact round trip.
    ASSERT_EQ(received[i].sample.timestamp, truth[i].timestamp) << i;
    ASSERT_EQ(received[i].sample.gyro, truth[i].gyro) << i;
    ASSERT_EQ(received[i].sample.accel, truth[i].accel) << i;
    if (i > 0) {
      EXPECT_GE(received[i].host_receive_time, received[i - 1].host_receive_time);
    }
  }
  EXPECT_EQ(stats.samples, truth.size());
  EXPECT_EQ(stats.malformed, malformed_sent);
  EXPECT_EQ(stats.out_of_order, out_of_order_sent);
  EXPECT_EQ(stats.overflow, 0u);
  ASSERT_TRUE(stats.first_malformed.has_value());
  EXPECT_EQ(*stats.first_malformed, first_garbage);
}

TEST(ImuUdpLoopback, SensorstreamDatagramsAndOverflow) {
  ImuUdpOptions options;
  options.max_pending = 10;
  auto listener = ImuUdpListener::open(options);
  ASSERT_TRUE(listener.ok()) << listener.error().describe();
  UdpSender sender(listener->port());
  for (int i = 0; i < 25; ++i) {
    const std::string stamp = std::to_string(500 + i) + ".12345";
    sender.send(stamp + ", 3, 0.100,9.810,0.200, 4, 0.010,0.020," + std::to_string(i) +
                ".000, 5, 1.000,2.000,3.000");
  }
  sender.send("600.0, 3, 0.1,9.8,0.2");  // no gyroscope
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (listener->stats().datagrams < 26 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const auto samples = listener->take_samples();
  const auto stats = listener->stats();
  EXPECT_EQ(stats.samples, 25u);
  EXPECT_EQ(stats.incomplete, 1u);
  EXPECT_EQ(stats.overflow, 15u);
  ASSERT_EQ(samples.size(), 10u);  // the newest ten
  EXPECT_EQ(samples.front().sample.timestamp, 515.12345);
  EXPECT_EQ(samples.back().sample.gyro, Eigen::Vector3d(0.01, 0.02, 24.0));
}

}  // namespace
}  // namespace imufusion
