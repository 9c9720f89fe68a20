#pragma once
// IMU samples streamed from a phone over UDP, for live scanning.
//
// Two line formats are accepted (a datagram may hold several lines, '\n' separated):
//
// - imufusion's imu.txt line (FORMAT.md): `timestamp wx wy wz ax ay az`, seconds, rad/s, m/s^2,
//   separated by spaces (or commas).
// - The CSV of the Android app "Sensorstream IMU+GPS" (de.lorenz_fenster.sensorstreamgps), one
//   datagram per accelerometer event:
//     `t, 3, ax, ay, az, 4, gx, gy, gz, 5, mx, my, mz[, ID, values...]`
//   t: the Android event timestamp (nanoseconds since boot) in seconds, 5 decimals; then pairs of
//   a sensor id and its values: 1 GPS latitude/longitude/altitude (3, placed before 3), 3
//   accelerometer m/s^2 (3), 4 gyroscope rad/s (3), 5 magnetometer uT (3), 6 WGS84 position
//   (3), 7 velocity (3), 8 GPS UTC time (1), 81 orientation (3), 82 linear acceleration (3),
//   83 gravity (3), 84 rotation vector (3), 85 rotation matrix (9), 86 quaternion (4),
//   87 pressure (1), 88 battery temperature (1). The app attaches the gyroscope only when its
//   latest reading is within 0.5 s of the accelerometer's; a line without both 3 and 4 gives no
//   sample (counted in `incomplete`). Axes are Android's device frame (x right, y up, z out of
//   the screen), the phone IMU frame of synth.hpp; the accelerometer reads specific force
//   (+9.81 up at rest), as imu.txt.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion {

/// Seconds on the host's monotonic clock (std::chrono::steady_clock): the clock live sources
/// map their timestamps onto.
double host_clock_now();

/// What one line was.
enum class ImuLineKind { kSample, kIncomplete, kMalformed, kEmpty };

/// Parses one line in either format. kSample fills `sample`; kIncomplete is a well-formed
/// Sensorstream line without accelerometer or gyroscope; kEmpty a blank or `#` comment line.
ImuLineKind parse_imu_line(std::string_view line, ImuSample* sample);

/// Bounds of a real measurement: a sample beyond them (a corrupt line, a broken sensor) is
/// rejected and counted, never used; so is a sample that jumps in time (see max_interval).
struct ImuSampleLimits {
  /// Largest |rate| on any gyro axis, rad/s; default 35 (2000 deg/s, the full scale of phone
  /// and depth-camera gyros, and 5.5 turns a second, beyond any hand-held motion).
  double max_gyro = 35.0;
  /// Largest |specific force| on any accelerometer axis, m/s^2; default 160 (16 g full scale).
  double max_accel = 160.0;
  /// A sample more than this after the last accepted one (seconds; default 1) is held until
  /// `jump_confirmations` (default 3) samples continue from it; if the stream goes on from
  /// before it instead, it was a jump in time and is rejected. A stream starts the same way.
  double max_interval = 1.0;
  int jump_confirmations = 3;
};

/// One received sample with the host time its datagram arrived (host_clock_now()).
struct ReceivedImuSample {
  ImuSample sample;  // on the phone's clock
  double host_receive_time = 0;
};

struct ImuUdpOptions {
  /// UDP port; 0 picks a free one (see ImuUdpListener::port()).
  std::uint16_t port = 0;
  /// IPv4 address to listen on. Loopback by default: listening on a network interface (e.g.
  /// "0.0.0.0" or the Wi-Fi address) must be asked for explicitly.
  std::string address = "127.0.0.1";
  /// Samples held for take_samples(); beyond this the oldest are dropped (counted in
  /// `overflow`), so a caller that stops polling cannot exhaust memory (200 Hz: ~5 minutes).
  std::size_t max_pending = 65536;
  ImuSampleLimits limits;
};

/// Counters since open(); a sample or line is counted once.
struct ImuStreamStats {
  std::size_t datagrams = 0;     // datagrams received
  std::size_t samples = 0;       // samples accepted
  std::size_t malformed = 0;     // lines that are not a valid line of either format
  std::size_t incomplete = 0;    // valid Sensorstream lines without accelerometer + gyroscope
  std::size_t out_of_order = 0;  // samples whose timestamp is not after the previous one
  std::size_t implausible = 0;   // samples beyond ImuSampleLimits' rates and forces, or NaN/inf
  std::size_t time_jumps = 0;    // samples rejected as a jump in time (ImuSampleLimits)
  std::size_t overflow = 0;      // accepted samples dropped because nobody took them
  std::optional<std::string> first_malformed;  // the first malformed line (up to 120 bytes)
};

/// Receives IMU lines on a UDP socket in a background thread. Never blocks the caller: the
/// scanner polls take_samples() once per frame. Malformed lines, samples out of order,
/// implausible samples and jumps in time are counted and dropped, never fatal. Move-only; the
/// destructor stops the thread.
class ImuUdpListener {
 public:
  /// Binds the socket and starts the thread. Fails (kInvalidArgument) on an address that is
  /// not IPv4 dotted-quad, and (kIoError, with the system's reason) when the socket cannot be
  /// bound, e.g. the port is in use.
  static Result<ImuUdpListener> open(const ImuUdpOptions& options);

  ImuUdpListener(ImuUdpListener&&) noexcept;
  ImuUdpListener& operator=(ImuUdpListener&&) noexcept;
  ~ImuUdpListener();

  /// The samples received since the last call, oldest first, strictly increasing timestamps.
  std::vector<ReceivedImuSample> take_samples();
  ImuStreamStats stats() const;
  /// The bound port (the one chosen when options.port was 0).
  std::uint16_t port() const;
  /// The address listened on, e.g. "127.0.0.1:5555".
  std::string endpoint() const;
  /// Stops the thread and closes the socket; take_samples() still returns what was received.
  void stop();

 private:
  struct State;
  explicit ImuUdpListener(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace imufusion
