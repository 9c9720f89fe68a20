// Hostile sequence files: a FIFO or a device where a file should be, files beyond the size
// limit, intrinsics no camera has, and IMU samples no real IMU gives. Each is refused or left
// out with a message naming the file and value, and never hangs or exhausts memory.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <future>
#include <string>

#include "imufusion/image_io.hpp"
#include "imufusion/sequence.hpp"
#include "io/atomic_file.hpp"
#include "io/sequence_check.hpp"
#include "io_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::write_text;

constexpr int kWidth = 32, kHeight = 24, kFrames = 4;

class HostileFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string depth;
    for (int i = 0; i < kFrames; ++i) {
      const std::string name = "depth/" + std::to_string(i) + ".png";
      fs::create_directories(dir / "depth");
      ASSERT_TRUE(write_depth_png(dir / name, testing::make_depth(kWidth, kHeight, i)).ok());
      depth += std::to_string(0.1 * i) + " " + name + "\n";
    }
    write_text(dir / "depth.txt", depth);
    write_text(dir / "calibration.txt", "30 31 16 12\n");
    std::string imu;
    for (int k = 0; k <= 80; ++k) imu += std::to_string(-0.05 + 0.005 * k) + " 0.1 0 0 0 9.8 0\n";
    write_text(dir / "imu.txt", imu);
  }

  // SequenceReader::open, which must fail, with a deadline: a FIFO that blocks it is given a
  // writer that closes at once, so the test ends either way.
  std::string open_error_within(const fs::path& fifo, std::chrono::seconds deadline) {
    auto opened = std::async(std::launch::async, [&] { return SequenceReader::open(dir.path()); });
    if (opened.wait_for(deadline) != std::future_status::ready) {
      const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
      if (fd >= 0) ::close(fd);
      opened.wait();
      ADD_FAILURE() << "opening the sequence blocked on " << fifo;
      return {};
    }
    auto reader = opened.get();
    EXPECT_FALSE(reader.ok());
    return reader.ok() ? std::string() : reader.error().describe();
  }

  TempDir dir;
};

TEST_F(HostileFiles, TheFixtureIsASoundSequence) {
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->imu().size(), 81u);
  EXPECT_EQ(reader->info().imu_implausible, 0u);
  EXPECT_EQ(reader->info().imu_time_jumps, 0u);
}

TEST_F(HostileFiles, AFifoGroundTruthIsRefusedWithoutWaiting) {
  const fs::path fifo = dir / "groundtruth.txt";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string error = open_error_within(fifo, std::chrono::seconds(20));
  EXPECT_NE(error.find(fifo.string()), std::string::npos) << error;
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
  const io::SequenceCheck check = io::check_sequence(dir.path(), nullptr);
  EXPECT_FALSE(check.scannable);
}

TEST_F(HostileFiles, ADeviceAsImuTxtIsRefusedBeforeItIsRead) {
  fs::remove(dir / "imu.txt");
  fs::create_symlink("/dev/zero", dir / "imu.txt");
  auto reader = SequenceReader::open(dir.path());
  ASSERT_FALSE(reader.ok());
  EXPECT_NE(reader.error().message.find((dir / "imu.txt").string()), std::string::npos)
      << reader.error().message;
  EXPECT_NE(reader.error().message.find("not a regular file"), std::string::npos);
}

TEST(ReadFileBytes, AFileOverItsLimitIsRefusedNamingIt) {
  TempDir dir;
  write_text(dir / "big.txt", std::string(101, 'x'));
  auto bytes = io::read_file_bytes(dir / "big.txt", 100);
  ASSERT_FALSE(bytes.ok());
  EXPECT_NE(bytes.error().message.find("big.txt"), std::string::npos);
  EXPECT_NE(bytes.error().message.find("100-byte limit"), std::string::npos)
      << bytes.error().message;
  EXPECT_TRUE(io::read_file_bytes(dir / "big.txt", 101).ok());
  EXPECT_EQ(io::read_file_bytes(dir / "none.txt").error().code, ErrorCode::kNotFound);
}

TEST_F(HostileFiles, IntrinsicsNoCameraHasAreRefusedNamingTheValue) {
  const struct {
    const char* line;
    const char* named;
  } cases[] = {{"1e-06 31 16 12\n", "fx 1e-06"},  // a field of view of 180 degrees
               {"30 1e+06 16 12\n", "fy 1e+06"},  // 0.001 degrees
               {"30 31 1e+09 12\n", "cx 1e+09"},
               {"30 31 16 -3\n", "must be positive"},
               {"30 31 16 25\n", "cy 25"}};  // below the image
  for (const auto& c : cases) {
    write_text(dir / "calibration.txt", c.line);
    auto reader = SequenceReader::open(dir.path());
    ASSERT_FALSE(reader.ok()) << c.line;
    EXPECT_NE(reader.error().message.find((dir / "calibration.txt").string()), std::string::npos)
        << reader.error().message;
    EXPECT_NE(reader.error().message.find(c.named), std::string::npos) << reader.error().message;
    EXPECT_FALSE(io::check_sequence(dir.path(), nullptr).scannable) << c.line;
  }
  SequenceOptions options;
  options.intrinsics = Intrinsics{1e-6, 31, 16, 12, 0, 0};
  fs::remove(dir / "calibration.txt");
  auto reader = SequenceReader::open(dir.path(), options);
  ASSERT_FALSE(reader.ok());
  EXPECT_NE(reader.error().message.find("passed by the caller: fx 1e-06"), std::string::npos)
      << reader.error().message;
}

TEST_F(HostileFiles, ImpossibleImuSamplesAndJumpsInTimeAreLeftOutAndCounted) {
  std::string imu;
  for (int k = 0; k <= 80; ++k) {
    std::string gyro = "0.1 0 0";
    if (k == 20) gyro = "1e300 0 0";
    if (k == 30) gyro = "0 1000 0";
    imu += std::to_string(-0.05 + 0.005 * k) + " " + gyro + " 0 9.8 0\n";
    if (k == 40) imu += "1000000.0 0.1 0 0 0 9.8 0\n";
  }
  write_text(dir / "imu.txt", imu);
  auto reader = SequenceReader::open(dir.path());
  ASSERT_TRUE(reader.ok()) << reader.error().describe();
  EXPECT_EQ(reader->info().imu_implausible, 2u);
  EXPECT_EQ(reader->info().imu_time_jumps, 1u);
  ASSERT_EQ(reader->imu().size(), 79u);
  for (const ImuSample& sample : reader->imu()) {
    EXPECT_LT(sample.gyro.norm(), 1.0);
    EXPECT_LT(sample.timestamp, 1.0);
  }
  const io::SequenceCheck check = io::check_sequence(dir.path(), nullptr);
  EXPECT_TRUE(check.scannable);
  ASSERT_FALSE(check.warnings.empty());
  bool reported = false;
  for (const auto& w : check.warnings) reported |= w.find("2 samples beyond") != std::string::npos;
  EXPECT_TRUE(reported);
}

TEST_F(HostileFiles, ImuCoveringNoFrameIsReported) {
  std::string imu;
  for (int k = 0; k <= 80; ++k) imu += std::to_string(500.0 + 0.005 * k) + " 0.1 0 0 0 9.8 0\n";
  write_text(dir / "imu.txt", imu);
  const io::SequenceCheck check = io::check_sequence(dir.path(), nullptr);
  EXPECT_TRUE(check.scannable);
  EXPECT_EQ(check.frames_within_imu, 0u);
  bool reported = false;
  for (const auto& w : check.warnings) {
    reported |= w.find("covers none of the depth frames") != std::string::npos;
  }
  EXPECT_TRUE(reported);
}

}  // namespace
}  // namespace imufusion
