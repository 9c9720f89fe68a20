#pragma once
// Streams datagrams to a tool listening on a loopback UDP port (--imu-udp), each at its time
// after the tool's stderr says it listens, from a thread of its own.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tool_runner.hpp"

namespace imufusion::test {

/// A UDP port that was free a moment ago (the kernel's pick for port 0).
inline std::uint16_t free_udp_port() {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t length = sizeof addr;
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &length) == 0;
  close(fd);
  EXPECT_TRUE(ok) << "no free UDP port";
  return ntohs(addr.sin_port);
}

/// The data lines of imu.txt with their timestamps (seconds).
inline std::vector<std::pair<double, std::string>> imu_lines(const std::filesystem::path& imu_txt) {
  std::vector<std::pair<double, std::string>> lines;
  std::istringstream in(read_text(imu_txt));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    lines.emplace_back(std::stod(line), line);
  }
  return lines;
}

class UdpReplay {
 public:
  /// Sends each (seconds after the start, payload) once `tool_err` contains "listening on".
  UdpReplay(std::uint16_t port, std::filesystem::path tool_err,
            std::vector<std::pair<double, std::string>> datagrams)
      : thread_([this, port, tool_err = std::move(tool_err), datagrams = std::move(datagrams)] {
          run(port, tool_err, datagrams);
        }) {}
  ~UdpReplay() { stop(); }
  UdpReplay(const UdpReplay&) = delete;
  UdpReplay& operator=(const UdpReplay&) = delete;

  void stop() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
  }
  std::size_t sent() const { return sent_; }

 private:
  using Clock = std::chrono::steady_clock;

  void run(std::uint16_t port, const std::filesystem::path& tool_err,
           const std::vector<std::pair<double, std::string>>& datagrams) {
    const auto give_up = Clock::now() + std::chrono::seconds(300);
    while (!done_ && read_text(tool_err).find("listening on") == std::string::npos) {
      if (Clock::now() > give_up) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    const int fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(port);
    const auto start = Clock::now();
    for (const auto& [t, payload] : datagrams) {
      if (done_) break;
      std::this_thread::sleep_until(start + std::chrono::duration<double>(std::max(0.0, t)));
      if (sendto(fd, payload.data(), payload.size(), 0, reinterpret_cast<sockaddr*>(&to),
                 sizeof to) > 0) {
        ++sent_;
      }
    }
    close(fd);
  }

  std::atomic<bool> done_{false};
  std::atomic<std::size_t> sent_{0};
  std::thread thread_;
};

}  // namespace imufusion::test
