#include "imufusion/result.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "imufusion/reconstructor.hpp"

using namespace imufusion;

namespace {

// The message of the config check that fails first on a default config (no device is needed).
constexpr const char* kEmptyIntrinsics = "intrinsics size 0x0 is empty";

Result<std::string> failed() { return make_error(ErrorCode::kNotFound, "depth.txt missing", -4); }

std::string what_of_value(const Result<std::string>& result) {
  try {
    (void)result.value();
  } catch (const BadResultAccess& e) {
    return e.what();
  }
  return "no exception";
}

}  // namespace

TEST(Result, ValueOfAnErrorThrowsWithTheHeldError) {
  const Result<std::string> result = failed();
  EXPECT_EQ(what_of_value(result),
            "value() of a Result holding an error: not found: depth.txt missing (VkResult -4)");
  try {
    (void)*failed();
    FAIL() << "operator* returned";
  } catch (const BadResultAccess& e) {
    EXPECT_EQ(e.error().code, ErrorCode::kNotFound);
    EXPECT_EQ(e.error().message, "depth.txt missing");
    EXPECT_EQ(e.error().vk_result, -4);
  }
  Result<std::string> mutable_result = failed();
  EXPECT_THROW((void)mutable_result->size(), BadResultAccess);
  EXPECT_THROW((void)std::move(mutable_result).value(), BadResultAccess);
}

TEST(Result, AccessorsOfTheHeldAlternativeDoNotThrow) {
  Result<std::string> result = std::string("frames");
  EXPECT_EQ(result.value(), "frames");
  EXPECT_EQ(result->size(), 6u);
  EXPECT_THROW((void)result.error(), BadResultAccess);
  EXPECT_EQ(std::move(result).value(), "frames");
  EXPECT_EQ(failed().error().message, "depth.txt missing");
}

TEST(Result, UncheckedReconstructorCreateReportsTheConfigError) {
  auto created = Reconstructor::create({});
  ASSERT_FALSE(created.ok());
  try {
    (void)created->device();
    FAIL() << "operator-> returned";
  } catch (const BadResultAccess& e) {
    EXPECT_NE(std::string(e.what()).find(kEmptyIntrinsics), std::string::npos) << e.what();
  }
}

// An application that never catches: the exception leaves a noexcept frame as it would leave
// main(), std::terminate runs, and the runtime prints what() before aborting.
TEST(ResultDeathTest, UncaughtAccessTerminatesWithTheMessage) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  const auto unchecked = []() noexcept { (void)Reconstructor::create({}).value(); };
  EXPECT_DEATH(unchecked(),
               "value\\(\\) of a Result holding an error: invalid argument: .*intrinsics size "
               "0x0 is empty");
}
