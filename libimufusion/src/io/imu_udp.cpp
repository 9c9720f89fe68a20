// UDP receiver of imu_stream.hpp: one background thread, a mutex-protected pending list.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>

#include "imufusion/imu_stream.hpp"
#include "io/imu_gate.hpp"

namespace imufusion {
namespace {

// The largest UDP payload; a Sensorstream datagram is ~150 bytes.
constexpr std::size_t kMaxDatagram = 65507;
// How often the thread looks at the stop flag while no datagram comes (milliseconds).
constexpr int kPollMilliseconds = 50;

std::string system_error(const char* what) {
  return std::string(what) + ": " + std::strerror(errno);
}

}  // namespace

struct ImuUdpListener::State {
  ImuUdpOptions options;
  int socket = -1;
  std::uint16_t port = 0;
  std::thread thread;
  std::atomic<bool> stop{false};

  mutable std::mutex mutex;  // guards everything below
  std::deque<ReceivedImuSample> pending;
  ImuStreamStats stats;
  std::optional<io::ImuGate> gate;  // set at open(), from options.limits
  std::vector<ReceivedImuSample> released;

  void receive_loop();
  void handle_datagram(std::string_view datagram, double receive_time);
  void halt() {
    stop = true;
    if (thread.joinable()) thread.join();
    if (socket >= 0) ::close(socket);
    socket = -1;
  }
};

void ImuUdpListener::State::handle_datagram(std::string_view datagram, double receive_time) {
  std::lock_guard lock(mutex);
  ++stats.datagrams;
  std::size_t begin = 0;
  while (begin <= datagram.size()) {
    std::size_t end = datagram.find('\n', begin);
    if (end == std::string_view::npos) end = datagram.size();
    const std::string_view line = datagram.substr(begin, end - begin);
    begin = end + 1;
    ImuSample sample;
    switch (parse_imu_line(line, &sample)) {
      case ImuLineKind::kEmpty:
        continue;
      case ImuLineKind::kIncomplete:
        ++stats.incomplete;
        continue;
      case ImuLineKind::kMalformed:
        ++stats.malformed;
        if (!stats.first_malformed) stats.first_malformed = std::string(line.substr(0, 120));
        continue;
      case ImuLineKind::kSample:
        break;
    }
    released.clear();
    if (gate->push({sample, receive_time}, &released) == io::ImuVerdict::kOutOfOrder) {
      ++stats.out_of_order;
    }
    stats.implausible = gate->implausible();
    stats.time_jumps = gate->time_jumps();
    for (const ReceivedImuSample& accepted : released) {
      ++stats.samples;
      if (pending.size() >= options.max_pending) {
        pending.pop_front();
        ++stats.overflow;
      }
      pending.push_back(accepted);
    }
  }
}

void ImuUdpListener::State::receive_loop() {
  std::vector<char> buffer(kMaxDatagram + 1);
  while (!stop) {
    pollfd descriptor{socket, POLLIN, 0};
    const int ready = ::poll(&descriptor, 1, kPollMilliseconds);
    if (ready <= 0) continue;  // timeout, or EINTR: look at the stop flag again
    const ssize_t received = ::recv(socket, buffer.data(), kMaxDatagram, MSG_DONTWAIT);
    const double receive_time = host_clock_now();
    if (received < 0) continue;  // EAGAIN after a spurious wake-up, or an ICMP error
    handle_datagram(std::string_view(buffer.data(), static_cast<std::size_t>(received)),
                    receive_time);
  }
}

Result<ImuUdpListener> ImuUdpListener::open(const ImuUdpOptions& options) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(options.port);
  if (::inet_pton(AF_INET, options.address.c_str(), &address.sin_addr) != 1) {
    return make_error(ErrorCode::kInvalidArgument,
                      "IMU UDP address '" + options.address +
                          "' is not an IPv4 address (e.g. 127.0.0.1 or 0.0.0.0)");
  }
  if (options.max_pending == 0) {
    return make_error(ErrorCode::kInvalidArgument, "IMU UDP max_pending must be positive");
  }
  auto state = std::make_unique<State>();
  state->options = options;
  state->gate.emplace(options.limits);
  state->socket = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  const std::string endpoint = options.address + ":" + std::to_string(options.port);
  if (state->socket < 0) {
    return make_error(ErrorCode::kIoError,
                      system_error(("IMU UDP " + endpoint + ": socket").c_str()));
  }
  // A 200 Hz stream fills 64 KiB in well under a second only if the thread stalls; ask for
  // 1 MiB so scheduling hiccups drop nothing (the kernel may grant less).
  const int buffer_bytes = 1 << 20;
  ::setsockopt(state->socket, SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof(buffer_bytes));
  if (::bind(state->socket, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0) {
    Error error = make_error(ErrorCode::kIoError,
                             system_error(("IMU UDP cannot listen on " + endpoint).c_str()));
    ::close(state->socket);
    return error;
  }
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  ::getsockname(state->socket, reinterpret_cast<sockaddr*>(&bound), &length);
  state->port = ntohs(bound.sin_port);
  State* raw = state.get();
  state->thread = std::thread([raw] { raw->receive_loop(); });
  return ImuUdpListener(std::move(state));
}

ImuUdpListener::ImuUdpListener(std::unique_ptr<State> state) : state_(std::move(state)) {}
ImuUdpListener::ImuUdpListener(ImuUdpListener&&) noexcept = default;
ImuUdpListener& ImuUdpListener::operator=(ImuUdpListener&& other) noexcept {
  if (this != &other) {
    if (state_) state_->halt();
    state_ = std::move(other.state_);
  }
  return *this;
}
ImuUdpListener::~ImuUdpListener() {
  if (state_) state_->halt();
}

std::vector<ReceivedImuSample> ImuUdpListener::take_samples() {
  std::lock_guard lock(state_->mutex);
  std::vector<ReceivedImuSample> samples(state_->pending.begin(), state_->pending.end());
  state_->pending.clear();
  return samples;
}

ImuStreamStats ImuUdpListener::stats() const {
  std::lock_guard lock(state_->mutex);
  return state_->stats;
}

std::uint16_t ImuUdpListener::port() const { return state_->port; }

std::string ImuUdpListener::endpoint() const {
  return state_->options.address + ":" + std::to_string(state_->port);
}

void ImuUdpListener::stop() { state_->halt(); }

}  // namespace imufusion
