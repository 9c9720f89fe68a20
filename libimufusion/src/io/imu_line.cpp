// The two IMU line formats of imu_stream.hpp.

#include <charconv>
#include <chrono>
#include <cmath>

#include "imufusion/imu_stream.hpp"
#include "io/text_table.hpp"

namespace imufusion {
namespace {

std::optional<double> to_finite(std::string_view field) {
  double value = 0.0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || end != field.data() + field.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

std::optional<int> to_sensor_id(std::string_view field) {
  int value = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || end != field.data() + field.size()) return std::nullopt;
  return value;
}

// Values following each Sensorstream IMU+GPS sensor id (PreferencesActivity of the app).
int sensorstream_value_count(int id) {
  switch (id) {
    case 1:
    case 3:
    case 4:
    case 5:
    case 6:
    case 7:
    case 81:
    case 82:
    case 83:
    case 84:
      return 3;
    case 8:
    case 87:
    case 88:
      return 1;
    case 85:
      return 9;
    case 86:
      return 4;
    default:
      return -1;
  }
}

// Three finite values from fields[first]; the caller has checked they exist.
bool read_vector(const std::vector<std::string>& fields, std::size_t first, Eigen::Vector3d* v) {
  for (int a = 0; a < 3; ++a) {
    const auto value = to_finite(fields[first + a]);
    if (!value) return false;
    (*v)[a] = *value;
  }
  return true;
}

ImuLineKind parse_sensorstream(const std::vector<std::string>& fields, ImuSample* sample) {
  const auto timestamp = to_finite(fields[0]);
  if (!timestamp) return ImuLineKind::kMalformed;
  // Plain vectors and flags rather than std::optional<Vector3d>: GCC 12 reports a false
  // maybe-uninitialized on the latter.
  Eigen::Vector3d accel = Eigen::Vector3d::Zero(), gyro = Eigen::Vector3d::Zero();
  bool has_accel = false, has_gyro = false;
  std::size_t i = 1;
  while (i < fields.size()) {
    const auto id = to_sensor_id(fields[i]);
    if (!id) return ImuLineKind::kMalformed;
    const int count = sensorstream_value_count(*id);
    if (count < 0 || i + 1 + count > fields.size()) return ImuLineKind::kMalformed;
    for (int k = 0; k < count; ++k) {
      if (!to_finite(fields[i + 1 + k])) return ImuLineKind::kMalformed;
    }
    if (*id == 3) has_accel = read_vector(fields, i + 1, &accel);
    if (*id == 4) has_gyro = read_vector(fields, i + 1, &gyro);
    i += 1 + count;
  }
  if (!has_accel || !has_gyro) return ImuLineKind::kIncomplete;
  sample->timestamp = *timestamp;
  sample->accel = accel;
  sample->gyro = gyro;
  return ImuLineKind::kSample;
}

ImuLineKind parse_imu_txt(const std::vector<std::string>& fields, ImuSample* sample) {
  if (fields.size() != 7) return ImuLineKind::kMalformed;
  double values[7];
  for (int k = 0; k < 7; ++k) {
    const auto value = to_finite(fields[k]);
    if (!value) return ImuLineKind::kMalformed;
    values[k] = *value;
  }
  sample->timestamp = values[0];
  sample->gyro = Eigen::Vector3d(values[1], values[2], values[3]);
  sample->accel = Eigen::Vector3d(values[4], values[5], values[6]);
  return ImuLineKind::kSample;
}

}  // namespace

double host_clock_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

ImuLineKind parse_imu_line(std::string_view line, ImuSample* sample) {
  while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.remove_suffix(1);
  const auto fields = io::split_fields(line);
  if (fields.empty() || fields[0].front() == '#') return ImuLineKind::kEmpty;
  // Sensorstream separates with commas; imu.txt with spaces (commas tolerated, as in
  // text_table.hpp). A comma line is read as Sensorstream first.
  if (line.find(',') != std::string_view::npos && fields.size() >= 2) {
    ImuSample parsed;
    const ImuLineKind kind = parse_sensorstream(fields, &parsed);
    if (kind != ImuLineKind::kMalformed) {
      if (kind == ImuLineKind::kSample) *sample = parsed;
      return kind;
    }
  }
  return parse_imu_txt(fields, sample);
}

}  // namespace imufusion
