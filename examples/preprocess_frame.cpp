// Reads the first frame of a sequence and preprocesses it on the GPU: the smallest program that
// uses imufusion's sequence reader and depth preprocessing.
//   preprocess_frame SEQUENCE_DIR

#include <imufusion/preprocess.hpp>
#include <imufusion/sequence.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: preprocess_frame SEQUENCE_DIR\n";
    return 2;
  }
  auto reader = imufusion::SequenceReader::open(argv[1]);
  if (!reader) {
    std::cerr << reader.error().describe() << "\n";
    return 1;
  }
  if (!reader->intrinsics()) {
    std::cerr << argv[1] << " has no calibration.txt\n";
    return 1;
  }
  auto frame = reader->next();
  if (!frame) {
    std::cerr << frame.error().describe() << "\n";
    return 1;
  }
  imufusion::Intrinsics k = *reader->intrinsics();
  k.width = frame->depth.width;
  k.height = frame->depth.height;
  auto pre = imufusion::DepthPreprocessor::create(imufusion::PreprocessConfig{}, k);
  if (!pre) {
    std::cerr << pre.error().describe() << "\n";
    return 1;
  }
  auto out = pre->process(frame->depth);
  if (!out) {
    std::cerr << out.error().describe() << "\n";
    return 1;
  }
  for (std::size_t level = 0; level < out->normals.size(); ++level) {
    const imufusion::Vec4Image& normals = out->normals[level];
    std::size_t valid = 0;
    for (const auto& n : normals.data) valid += n.w() > 0 ? 1 : 0;
    std::cout << "level " << level << ": " << normals.width << "x" << normals.height << ", "
              << valid << " pixels with a vertex and a normal\n";
  }
  std::cout << "on " << pre->device().name << "\n";
  return 0;
}
