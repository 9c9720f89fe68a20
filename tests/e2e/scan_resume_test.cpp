// imufusion-scan --save-state and --resume on a small synthetic room with IMU: a scan saved after
// 17 frames and resumed with the rest writes the trajectory and mesh of the scan that never
// stopped, byte for byte; a state file that is missing or not a saved scan fails naming it.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "imufusion/synth.hpp"
#include "scan_test_fixtures.hpp"

namespace imufusion {
namespace {

namespace fs = std::filesystem;

class ScanResume : public test::ScanToolTest {
 protected:
  ScanResume() : ScanToolTest("imufusion_scan_resume_") {}
};

TEST_F(ScanResume, ASavedAndResumedScanWritesWhatOneScanWrites) {
  const fs::path seq =
      test::synthesize_small(scratch_.path(), "room", synth::SceneKind::kRoom, 36, 23);
  const auto whole = scan(seq.string() + " --out " + path("whole").string() + " --quiet");
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const fs::path state = path("room.imufusion");
  const auto first = scan(seq.string() + " --frames 17 --save-state " + state.string() + " --out " +
                          path("first").string() + " --quiet");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_TRUE(fs::exists(state));
  const auto rest = scan(seq.string() + " --resume " + state.string() + " --out " +
                         path("rest").string() + " --quiet");
  ASSERT_EQ(rest.exit_code, 0) << rest.err;
  EXPECT_NE(rest.out.find("scanned 19 frames"), std::string::npos) << rest.out;
  EXPECT_EQ(test::read_text(path("rest") / "trajectory.txt"),
            test::read_text(path("whole") / "trajectory.txt"));
  EXPECT_EQ(test::read_text(path("rest") / "mesh.ply"),
            test::read_text(path("whole") / "mesh.ply"));
  EXPECT_NE(test::read_text(path("first") / "trajectory.txt"),
            test::read_text(path("whole") / "trajectory.txt"));
}

TEST_F(ScanResume, AMissingOrForeignStateFileFailsNamingIt) {
  const fs::path seq =
      test::synthesize_small(scratch_.path(), "room", synth::SceneKind::kRoom, 4, 5);
  const auto missing = scan(seq.string() + " --resume " + path("none.imufusion").string() +
                            " --out " + path("out").string() + " --quiet");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("none.imufusion"), std::string::npos) << missing.err;
  const auto foreign = scan(seq.string() + " --resume " + (seq / "depth.txt").string() + " --out " +
                            path("out").string() + " --quiet");
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.err.find("not a saved scan"), std::string::npos) << foreign.err;
  EXPECT_FALSE(fs::exists(path("out") / "trajectory.txt"));
}

}  // namespace
}  // namespace imufusion
