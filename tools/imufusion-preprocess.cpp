// imufusion-preprocess [SEQUENCE] [options]
//
// Runs the GPU depth preprocessing (metres, bilateral filter, pyramid, vertex and normal maps)
// over every frame of a sequence and prints per-kernel GPU timings. With no SEQUENCE it first
// synthesizes the embedded demo scan (the furnished `room`) into --demo-dir.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "cli_common.hpp"
#include "demo_sequence.hpp"
#include "imufusion/device.hpp"
#include "imufusion/preprocess.hpp"
#include "imufusion/sequence.hpp"
#include "imufusion/synth.hpp"

namespace fs = std::filesystem;
using namespace imufusion;

namespace {

using tools::fail;
using tools::print_devices;

struct Options {
  std::string sequence;
  fs::path demo_dir = "demo";
  int demo_frames = 60;
  long max_frames = -1;
  std::string device;
  bool list_devices = false;
  bool quiet = false;
};

void usage(std::ostream& out) {
  out << "usage: imufusion-preprocess [SEQUENCE] [--frames N] [--device NAME|INDEX] "
         "[--list-devices]\n"
         "                            [--demo-dir DIR] [--demo-frames N] [--quiet]\n"
         "Runs the GPU depth preprocessing over SEQUENCE (a directory in the imufusion/TUM "
         "layout)\n"
         "and prints per-kernel GPU timings. Without SEQUENCE, synthesizes the demo room scan\n"
         "into --demo-dir (default ./demo) and uses it.\n";
}

bool parse_int(const std::string& text, long& out) {
  char* end = nullptr;
  out = std::strtol(text.c_str(), &end, 10);
  return !text.empty() && *end == '\0';
}

// Exit code 2 on a usage error, -1 to go on.
int parse(int argc, char** argv, Options& opt) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string& out) {
      if (i + 1 >= argc) return false;
      out = argv[++i];
      return true;
    };
    std::string v;
    long n = 0;
    if (arg == "-h" || arg == "--help") {
      usage(std::cout);
      return 0;
    } else if (arg == "--frames") {
      if (!value(v) || !parse_int(v, n) || n <= 0)
        return (std::cerr << "--frames needs a positive count\n", 2);
      opt.max_frames = n;
    } else if (arg == "--demo-frames") {
      if (!value(v) || !parse_int(v, n) || n <= 0)
        return (std::cerr << "--demo-frames needs a positive count\n", 2);
      opt.demo_frames = static_cast<int>(n);
    } else if (arg == "--demo-dir") {
      if (!value(v)) return (std::cerr << "--demo-dir needs a directory\n", 2);
      opt.demo_dir = v;
    } else if (arg == "--device") {
      if (!value(opt.device)) return (std::cerr << "--device needs a name or index\n", 2);
    } else if (arg == "--list-devices") {
      opt.list_devices = true;
    } else if (arg == "--quiet") {
      opt.quiet = true;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "unknown option " << arg << "\n";
      usage(std::cerr);
      return 2;
    } else if (opt.sequence.empty()) {
      opt.sequence = arg;
    } else {
      std::cerr << "more than one SEQUENCE given: " << opt.sequence << ", " << arg << "\n";
      return 2;
    }
  }
  return -1;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// The sequence to preprocess (the demo when none is given), with intrinsics and frames.
Result<SequenceReader> open_sequence(const Options& opt, fs::path& path) {
  path = opt.sequence;
  if (opt.sequence.empty()) {
    auto demo = tools::ensure_demo_sequence(opt.demo_dir, opt.demo_frames, SensorPreset::kKinect);
    if (!demo) return demo.error();
    path = *demo;
  }
  SequenceOptions seq_options;
  seq_options.load_color = false;
  auto reader = SequenceReader::open(path, seq_options);
  if (!reader) return reader.error();
  if (!reader->intrinsics()) {
    return Error{ErrorCode::kNotFound, (path / "calibration.txt").string() +
                                           " is missing: the sequence has no intrinsics"};
  }
  if (reader->frame_count() == 0)
    return Error{ErrorCode::kInvalidArgument, (path / "depth.txt").string() + " lists no frames"};
  return reader;
}

// Per-kernel GPU times and wall times of the frames preprocessed.
struct Timings {
  std::map<std::string, std::vector<double>> gpu_ms;  // kernel -> per-frame times
  std::vector<std::string> order;                     // kernels in dispatch order
  std::vector<double> frame_ms;
  double valid_fraction_sum = 0;
};

Status run_frames(const Options& opt, SequenceReader& reader, DepthPreprocessor& pre,
                  std::size_t total, Timings& t) {
  const bool progress = !opt.quiet && isatty(STDERR_FILENO);
  for (std::size_t i = 0; i < total; ++i) {
    auto frame = reader.next();
    if (!frame) return frame.error();
    const auto t0 = std::chrono::steady_clock::now();
    auto out = pre.process(frame->depth);
    const auto t1 = std::chrono::steady_clock::now();
    if (!out) {
      Error e = out.error();
      e.message = "frame " + std::to_string(i) + ": " + e.message;
      return e;
    }
    t.frame_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    for (const KernelTiming& k : out->timings) {
      if (!t.gpu_ms.count(k.kernel)) t.order.push_back(k.kernel);
      t.gpu_ms[k.kernel].push_back(k.gpu_ms);
    }
    std::size_t valid = 0;
    for (const auto& n : out->normals[0].data) valid += n.w() > 0 ? 1 : 0;
    t.valid_fraction_sum += double(valid) / double(out->normals[0].data.size());
    if (progress) std::cerr << "\rframe " << i + 1 << "/" << total << std::flush;
  }
  if (progress) std::cerr << "\n";
  return {};
}

void print_report(const Timings& t, std::size_t total) {
  std::printf("\n%-18s %10s %10s %10s\n", "kernel", "median ms", "mean ms", "max ms");
  double total_median = 0;
  for (const std::string& name : t.order) {
    const auto& v = t.gpu_ms.at(name);
    double sum = 0, max = 0;
    for (double x : v) {
      sum += x;
      max = std::max(max, x);
    }
    if (v.front() < 0) {
      std::printf("%-18s %10s\n", name.c_str(), "n/a (no GPU timestamps)");
      continue;
    }
    total_median += median(v);
    std::printf("%-18s %10.3f %10.3f %10.3f\n", name.c_str(), median(v), sum / double(v.size()),
                max);
  }
  std::printf("%-18s %10.3f\n", "sum of kernels", total_median);
  std::printf("\nwall time per frame (upload + kernels + download): median %.2f ms\n",
              median(t.frame_ms));
  std::printf("pixels with a valid normal at level 0: %.1f%% on average\n",
              100.0 * t.valid_fraction_sum / double(total));
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (const int rc = parse(argc, argv, opt); rc >= 0) return rc;
  if (opt.list_devices) return print_devices();

  fs::path path;
  auto reader = open_sequence(opt, path);
  if (!reader) return fail(reader.error().describe());
  const std::size_t total =
      opt.max_frames > 0
          ? std::min<std::size_t>(reader->frame_count(), static_cast<std::size_t>(opt.max_frames))
          : reader->frame_count();
  auto first = reader->frame(0);
  if (!first) return fail(first.error().describe());
  Intrinsics k = *reader->intrinsics();
  k.width = first->depth.width;
  k.height = first->depth.height;
  DeviceOptions device;
  device.selector = opt.device;
  auto pre = DepthPreprocessor::create(PreprocessConfig{}, k, device);
  if (!pre) return fail(pre.error().describe());
  std::cout << "sequence " << path.string() << ": " << total << " frames " << k.width << "x"
            << k.height << "\ndevice   " << pre->device().name << " ("
            << to_string(pre->device().type) << ")\n";

  Timings timings;
  if (auto s = run_frames(opt, *reader, *pre, total, timings); !s) {
    std::cerr << "\n";
    return fail(s.error().describe());
  }
  print_report(timings, total);
  return 0;
}
