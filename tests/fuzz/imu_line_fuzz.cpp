// libFuzzer harness: one UDP datagram of IMU lines (imu_stream.hpp), split as the listener
// splits it, through the line parser and the sample gate; and the same bytes as a sequence text
// file through the table reader. Built and run by .ci/run (clang -fsanitize=fuzzer,address).

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "imufusion/imu_stream.hpp"
#include "io/imu_gate.hpp"
#include "io/text_table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view datagram(reinterpret_cast<const char*>(data), size);
  imufusion::io::ImuGate gate(imufusion::ImuSampleLimits{});
  std::vector<imufusion::ReceivedImuSample> released;
  std::size_t begin = 0;
  while (begin <= datagram.size()) {
    std::size_t end = datagram.find('\n', begin);
    if (end == std::string_view::npos) end = datagram.size();
    imufusion::ImuSample sample;
    if (imufusion::parse_imu_line(datagram.substr(begin, end - begin), &sample) ==
        imufusion::ImuLineKind::kSample) {
      gate.push({sample, 0.0}, &released);
    }
    begin = end + 1;
  }
  gate.finish(&released);
  for (const auto& field : imufusion::io::split_fields(datagram)) {
    (void)imufusion::io::parse_finite(field, "fuzz.txt", 1, "value");
    (void)imufusion::io::parse_integer(field, "fuzz.txt", 1, "value", -5, 5);
  }
  return 0;
}
