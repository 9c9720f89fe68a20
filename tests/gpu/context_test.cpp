// The Vulkan runtime: device listing and selection, failures as values, and the validation layer
// actually reporting misuse (so the GPU tests' "no validation errors" check can fail).

#include "vk/context.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <vector>

#include "gpu_test_env.hpp"
#include "imufusion/device.hpp"
#include "imufusion_layouts.h"
#include "vk/buffer.hpp"
#include "vk/command_sequence.hpp"
#include "vk/pipeline.hpp"

namespace imufusion {
namespace {

using test::GpuTest;

TEST_F(GpuTest, ListsTheDeviceItRunsOn) {
  auto devices = list_devices();
  ASSERT_TRUE(devices.ok()) << devices.error().describe();
  ASSERT_FALSE(devices->empty());
  bool found = false;
  for (const DeviceInfo& d : *devices) found |= d.name == context_->info().name;
  EXPECT_TRUE(found);
}

TEST_F(GpuTest, SelectsByNameSubstringAndIndex) {
  const DeviceInfo& info = context_->info();
  DeviceOptions by_name;
  by_name.selector = info.name.substr(0, 4);
  auto a = gpu::Context::create(by_name);
  ASSERT_TRUE(a.ok()) << a.error().describe();
  EXPECT_EQ((*a)->info().name, info.name);
  DeviceOptions by_index;
  by_index.selector = std::to_string(info.index);
  auto b = gpu::Context::create(by_index);
  ASSERT_TRUE(b.ok()) << b.error().describe();
  EXPECT_EQ((*b)->info().index, info.index);
}

TEST_F(GpuTest, UnknownSelectorIsANoDeviceErrorListingTheDevices) {
  DeviceOptions options;
  options.selector = "no-such-device-xyz";
  auto context = gpu::Context::create(options);
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().code, ErrorCode::kNoDevice);
  EXPECT_NE(context.error().message.find("no-such-device-xyz"), std::string::npos);
  EXPECT_NE(context.error().message.find(context_->info().name), std::string::npos);
}

TEST_F(GpuTest, EnvironmentVariableChoosesTheDevice) {
  ::setenv("IMUFUSION_DEVICE", "no-such-device-xyz", 1);
  auto context = gpu::Context::create({});
  ::unsetenv("IMUFUSION_DEVICE");
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().code, ErrorCode::kNoDevice);
}

TEST_F(GpuTest, ImpossibleAllocationIsAnOutOfMemoryError) {
  // Without validation: the request itself is invalid usage, which is the point of the test.
  auto plain = gpu::Context::create({});
  ASSERT_TRUE(plain.ok());
  auto buffer = gpu::Buffer::create(*plain, VkDeviceSize{1} << 50);
  ASSERT_FALSE(buffer.ok());
  EXPECT_EQ(buffer.error().code, ErrorCode::kOutOfDeviceMemory) << buffer.error().describe();
  EXPECT_NE(buffer.error().vk_result, 0);
}

TEST_F(GpuTest, BufferRoundTripAndRangeChecks) {
  auto buffer = gpu::Buffer::create(context_, 10);  // rounded up to 12 bytes
  ASSERT_TRUE(buffer.ok());
  EXPECT_EQ(buffer->size(), 12u);
  const std::vector<float> values{1.5f, -2.0f, 3.25f};
  ASSERT_TRUE(buffer->upload(std::span<const float>(values)).ok());
  auto back = buffer->download_as<float>(3);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, values);
  EXPECT_FALSE(buffer->upload(values.data(), 16).ok());
  EXPECT_FALSE(buffer->download(nullptr, 4, 12).ok());
}

// Transfers recorded between dispatches: a fill, then a copy of what it wrote, in one submission
// (device-local and host-visible buffers), each timed like a dispatch; a copy larger than its
// buffers is an error at submit.
TEST_F(GpuTest, FillAndCopyRunInOrderInOneSubmission) {
  auto device = gpu::Buffer::create(context_, 64);
  auto host = gpu::Buffer::create(context_, 64, true);
  auto seq = gpu::CommandSequence::create(context_, 2);
  ASSERT_TRUE(device.ok() && host.ok() && seq.ok());
  ASSERT_TRUE(seq->begin().ok());
  seq->fill(*device, 0x3f800000u, "fill");  // 1.0f
  seq->copy(*device, *host, 64, "copy");
  auto timings = seq->submit_and_wait();
  ASSERT_TRUE(timings.ok()) << timings.error().describe();
  ASSERT_EQ(timings->size(), 2u);
  EXPECT_EQ((*timings)[1].kernel, "copy");
  auto back = host->download_as<float>(16);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, std::vector<float>(16, 1.0f));
  ASSERT_TRUE(seq->begin().ok());
  seq->copy(*device, *host, 128, "too large");
  auto failed = seq->submit_and_wait();
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.error().message.find("too large"), std::string::npos);
}

// A submission not waited for is seen by the next one on the queue; begin() before its wait()
// and a wait() without a submission are errors.
TEST_F(GpuTest, LaterSubmissionSeesAnUnwaitedOne) {
  auto device = gpu::Buffer::create(context_, 64);
  auto host = gpu::Buffer::create(context_, 64, true);
  auto first = gpu::CommandSequence::create(context_, 1);
  auto second = gpu::CommandSequence::create(context_, 1);
  ASSERT_TRUE(device.ok() && host.ok() && first.ok() && second.ok());
  EXPECT_FALSE(first->wait().ok());
  ASSERT_TRUE(first->begin().ok());
  first->fill(*device, 0x40000000u, "fill");  // 2.0f
  ASSERT_TRUE(first->submit().ok());
  EXPECT_TRUE(first->pending());
  EXPECT_FALSE(first->begin().ok());
  ASSERT_TRUE(second->begin().ok());
  second->copy(*device, *host, 64, "copy");
  ASSERT_TRUE(second->submit_and_wait().ok());
  auto back = host->download_as<float>(16);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, std::vector<float>(16, 2.0f));
  auto timings = first->wait();
  ASSERT_TRUE(timings.ok()) << timings.error().describe();
  EXPECT_EQ(timings->size(), 1u);
  EXPECT_FALSE(first->pending());
  EXPECT_FALSE(first->wait().ok());
}

// The volume's indirect workgroup counts, made on the GPU from its counters and dispatched
// indirectly themselves: a 2-D grid of at most VOLUME_INTEGRATE_GROUPS_X groups per row for
// integration, one invocation per stored block (capped at the capacity) for the range pass.
TEST_F(GpuTest, IndirectDispatchTakesItsCountsFromTheGpu) {
  auto pipeline = gpu::ComputePipeline::create(
      context_, {"volume_dispatch_args", 2, sizeof(gpu::layout::VolumeArgsParams), 1, 1});
  auto counters = gpu::Buffer::create(context_, VOLUME_COUNTERS * 4);
  auto args = gpu::Buffer::create(context_, VOLUME_ARGS_WORDS * 4);
  auto ones = gpu::Buffer::create(context_, 12);
  auto seq = gpu::CommandSequence::create(context_, 3);
  ASSERT_TRUE(pipeline.ok() && counters.ok() && args.ok() && ones.ok() && seq.ok());
  for (const std::uint32_t capacity : {100000u, 1000u}) {
    gpu::layout::VolumeArgsParams p{};
    p.pool_blocks = capacity;
    ASSERT_TRUE(seq->begin().ok());
    seq->fill(*counters, 70000, "counters");  // 70000 listed slots and allocated blocks
    seq->fill(*ones, 1, "one group");
    seq->dispatch_indirect(*pipeline, {&*counters, &*args}, p, *ones, 0, "args");
    ASSERT_TRUE(seq->submit_and_wait().ok());
    auto words = args->download_as<std::uint32_t>(VOLUME_ARGS_WORDS);
    ASSERT_TRUE(words.ok());
    EXPECT_EQ((*words)[VOLUME_ARGS_INTEGRATE], 32768u);
    EXPECT_EQ((*words)[VOLUME_ARGS_INTEGRATE + 1], 3u);  // 3 x 32768 >= 70000
    EXPECT_EQ((*words)[VOLUME_ARGS_INTEGRATE + 2], 1u);
    EXPECT_EQ((*words)[VOLUME_ARGS_RANGE], (std::min(70000u, capacity) + 63) / 64);
    EXPECT_EQ((*words)[VOLUME_ARGS_RANGE + 1], 1u);
  }
  ASSERT_TRUE(seq->begin().ok());
  seq->dispatch_indirect(*pipeline, {&*counters, &*args}, gpu::layout::VolumeArgsParams{}, *ones, 4,
                         "args out of range");
  EXPECT_FALSE(seq->submit_and_wait().ok());
}

TEST_F(GpuTest, UnknownShaderIsAnError) {
  auto pipeline = gpu::ComputePipeline::create(context_, {"no_such_shader", 1, 0, 8, 8});
  ASSERT_FALSE(pipeline.ok());
  EXPECT_NE(pipeline.error().message.find("no_such_shader"), std::string::npos);
}

TEST(ValidationLayer, ReportsInvalidUsage) {
  DeviceOptions options;
  options.validation = true;
  auto context = gpu::Context::create(options);
  if (!context.ok()) GTEST_SKIP() << context.error().describe();
  if (!(*context)->validation_enabled()) GTEST_SKIP() << "vulkan-validationlayers not installed";
  // A buffer of size 0 violates VUID-VkBufferCreateInfo-size-00912.
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = 0;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  VkBuffer buffer = VK_NULL_HANDLE;
  vkCreateBuffer((*context)->device(), &info, nullptr, &buffer);
  if (buffer != VK_NULL_HANDLE) vkDestroyBuffer((*context)->device(), buffer, nullptr);
  EXPECT_GT((*context)->validation_error_count(), 0u);
}

}  // namespace
}  // namespace imufusion
