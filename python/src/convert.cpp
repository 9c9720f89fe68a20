#include "convert.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace imufusion::python {

namespace {

std::string shape_text(const py::array& array) {
  std::string text = "(";
  for (py::ssize_t i = 0; i < array.ndim(); ++i) {
    if (i > 0) text += ", ";
    text += std::to_string(array.shape(i));
  }
  return text + (array.ndim() == 1 ? ",)" : ")");
}

[[noreturn]] void bad_array(const char* name, const std::string& expected,
                            const py::handle& value) {
  throw py::value_error(std::string(name) + ": expected " + expected + ", got " +
                        describe_array(value));
}

py::array as_array(const py::handle& value, const char* name, const std::string& expected) {
  if (!py::isinstance<py::array>(value)) bad_array(name, expected, value);
  return py::reinterpret_borrow<py::array>(value);
}

template <typename T>
bool has_dtype(const py::array& array) {
  return array.dtype().equal(py::dtype::of<T>());
}

// A C-contiguous copy (or view) of an array whose dtype is T.
template <typename T>
py::array_t<T, py::array::c_style> contiguous(const py::array& array) {
  return py::array_t<T, py::array::c_style>::ensure(array);
}

// A float array of `rows` x `cols` (rows -1: any) as float64, C order.
py::array_t<double, py::array::c_style> float_matrix(const py::handle& value, const char* name,
                                                     py::ssize_t rows, py::ssize_t cols) {
  const std::string expected = "a float array of shape (" +
                               (rows < 0 ? std::string("N") : std::to_string(rows)) + ", " +
                               std::to_string(cols) + ")";
  py::array array = as_array(value, name, expected);
  const bool real = has_dtype<double>(array) || has_dtype<float>(array);
  if (!real || array.ndim() != 2 || (rows >= 0 && array.shape(0) != rows) || array.shape(1) != cols)
    bad_array(name, expected, value);
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
}

template <typename T>
py::array_t<T> new_array(std::vector<py::ssize_t> shape, const T* data) {
  py::array_t<T> array(shape);
  std::memcpy(array.mutable_data(), data, static_cast<std::size_t>(array.nbytes()));
  return array;
}

}  // namespace

void register_error(py::module_& m) {
  // Kept for the life of the process: Python may raise it until the interpreter is gone.
  static auto* type = new py::exception<ResultError>(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr thrown) {
    try {
      if (thrown) std::rethrow_exception(thrown);
    } catch (const ResultError& e) {
      py::object instance = py::reinterpret_borrow<py::object>(type->ptr())(e.what());
      instance.attr("code") = to_string(e.error().code);
      PyErr_SetObject(type->ptr(), instance.ptr());
    }
  });
}

std::string describe_array(const py::handle& value) {
  if (!py::isinstance<py::array>(value))
    return std::string(py::str(py::type::of(value).attr("__name__")));
  const auto array = py::reinterpret_borrow<py::array>(value);
  return std::string(py::str(array.dtype())) + " array of shape " + shape_text(array);
}

// A depth array as both readers take it: (H, W) uint16 raw units, or float32/float64 metres
// (`metres` set), with a positive finite depth_scale; ValueError naming `name` otherwise.
py::array checked_depth_array(const py::handle& value, double depth_scale, const char* name,
                              bool& metres) {
  const std::string expected = "a uint16 (raw units) or float32 (metres) array of shape (H, W)";
  py::array array = as_array(value, name, expected);
  metres = has_dtype<float>(array) || has_dtype<double>(array);
  if (array.ndim() != 2 || !(metres || has_dtype<std::uint16_t>(array)))
    bad_array(name, expected, value);
  if (!(depth_scale > 0) || !std::isfinite(depth_scale))
    throw py::value_error(std::string(name) + ": depth_scale must be positive, got " +
                          std::to_string(depth_scale));
  return array;
}

DepthImage depth_from_array(const py::handle& value, double depth_scale, const char* name) {
  bool metres = false;
  py::array array = checked_depth_array(value, depth_scale, name, metres);
  DepthImage image;
  image.height = static_cast<int>(array.shape(0));
  image.width = static_cast<int>(array.shape(1));
  image.depth_scale = depth_scale;
  image.data.resize(static_cast<std::size_t>(array.size()));
  if (!metres) {
    const auto raw = contiguous<std::uint16_t>(array);
    std::copy_n(raw.data(), image.data.size(), image.data.begin());
    return image;
  }
  const auto m = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  constexpr double kMaxRaw = std::numeric_limits<std::uint16_t>::max();
  for (std::size_t i = 0; i < image.data.size(); ++i) {
    const double raw = std::round(m.data()[i] * depth_scale);
    image.data[i] = raw > 0 && raw <= kMaxRaw ? static_cast<std::uint16_t>(raw) : 0;
  }
  return image;
}

ColorImage color_from_array(const py::handle& value, const char* name) {
  const std::string expected = "a uint8 array of shape (H, W, 3)";
  py::array array = as_array(value, name, expected);
  if (!has_dtype<std::uint8_t>(array) || array.ndim() != 3 || array.shape(2) != 3)
    bad_array(name, expected, value);
  ColorImage image;
  image.height = static_cast<int>(array.shape(0));
  image.width = static_cast<int>(array.shape(1));
  const auto rgb = contiguous<std::uint8_t>(array);
  image.data.assign(rgb.data(), rgb.data() + rgb.size());
  return image;
}

namespace {

// The array itself when its rows are packed pixels `pixel_bytes` apart at a positive stride of
// at least a row, else a C-contiguous copy as T.
template <typename T>
py::array with_packed_rows(const py::array& array, py::ssize_t pixel_bytes) {
  const py::ssize_t row = pixel_bytes * array.shape(1);
  if (array.strides(1) == pixel_bytes && array.strides(0) >= row &&
      array.strides(0) % static_cast<py::ssize_t>(sizeof(T)) == 0 &&
      (array.ndim() == 2 || array.strides(2) == static_cast<py::ssize_t>(sizeof(T))))
    return array;
  return contiguous<T>(array);
}

}  // namespace

ArrayView<DepthView> depth_view_of_array(const py::handle& value, double depth_scale,
                                         const char* name) {
  bool metres = false;
  py::array array = checked_depth_array(value, depth_scale, name, metres);
  const int h = static_cast<int>(array.shape(0)), w = static_cast<int>(array.shape(1));
  if (metres) {
    const py::array floats =
        has_dtype<float>(array)
            ? array
            : py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(array);
    py::array kept = with_packed_rows<float>(floats, sizeof(float));
    const auto stride = static_cast<std::size_t>(kept.strides(0));
    return {kept, DepthView::metres(static_cast<const float*>(kept.data()), w, h, stride)};
  }
  py::array kept = with_packed_rows<std::uint16_t>(array, sizeof(std::uint16_t));
  const auto stride = static_cast<std::size_t>(kept.strides(0));
  return {kept, DepthView::uint16(static_cast<const std::uint16_t*>(kept.data()), w, h, depth_scale,
                                  stride)};
}

ArrayView<ColorView> color_view_of_array(const py::handle& value, const char* name) {
  const std::string expected = "a uint8 array of shape (H, W, 3)";
  py::array array = as_array(value, name, expected);
  if (!has_dtype<std::uint8_t>(array) || array.ndim() != 3 || array.shape(2) != 3)
    bad_array(name, expected, value);
  py::array kept = with_packed_rows<std::uint8_t>(array, 3);
  return {kept, ColorView{static_cast<const std::uint8_t*>(kept.data()),
                          static_cast<int>(array.shape(1)), static_cast<int>(array.shape(0)),
                          static_cast<std::size_t>(kept.strides(0)), ColorFormat::kRgb8, 0}};
}

std::vector<ImuSample> imu_from_object(const py::handle& value, const char* name) {
  std::vector<ImuSample> samples;
  if (value.is_none()) return samples;
  if (!py::isinstance<py::array>(value)) {
    if (!py::isinstance<py::sequence>(value) || py::isinstance<py::str>(value))
      bad_array(name, "an (N, 7) float array or a list of ImuSample", value);
    for (const py::handle item : value) {
      if (!py::isinstance<ImuSample>(item))
        bad_array(name, "a list of ImuSample (or an (N, 7) float array) with no other items", item);
      samples.push_back(item.cast<ImuSample>());
    }
    return samples;
  }
  const auto a = float_matrix(value, name, -1, 7);
  samples.resize(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    ImuSample& s = samples[static_cast<std::size_t>(i)];
    s.timestamp = a.at(i, 0);
    s.gyro = {a.at(i, 1), a.at(i, 2), a.at(i, 3)};
    s.accel = {a.at(i, 4), a.at(i, 5), a.at(i, 6)};
  }
  return samples;
}

Eigen::Isometry3d pose_from_array(const py::handle& value, const char* name) {
  const auto a = float_matrix(value, name, 4, 4);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = a.at(r, c);
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const bool rigid =
      m.allFinite() && m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 1e-12) &&
      (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
      R.determinant() > 0;
  if (!rigid)
    throw py::value_error(std::string(name) +
                          ": expected a rigid transform (orthonormal rotation, last row 0 0 0 1)");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.matrix() = m;
  return pose;
}

Trajectory trajectory_from_object(const py::handle& value, const char* name) {
  Trajectory trajectory;
  if (!py::isinstance<py::array>(value) && py::isinstance<py::sequence>(value)) {
    for (const py::handle item : value) {
      if (!py::isinstance<py::sequence>(item) || py::len(item) != 2)
        bad_array(name, "a list of (t, 4x4 array) pairs", item);
      const auto pair = py::reinterpret_borrow<py::sequence>(item);
      trajectory.push_back({pair[0].cast<double>(), pose_from_array(pair[1], name)});
    }
    return trajectory;
  }
  const auto a = float_matrix(value, name, -1, 8);
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    StampedPose p;
    p.timestamp = a.at(i, 0);
    const Eigen::Quaterniond q(a.at(i, 7), a.at(i, 4), a.at(i, 5), a.at(i, 6));
    if (!(std::abs(q.norm() - 1) < 1e-3))
      throw py::value_error(std::string(name) + ": row " + std::to_string(i) +
                            " has a quaternion of norm " + std::to_string(q.norm()) + ", not 1");
    p.T_world_camera.linear() = q.normalized().toRotationMatrix();
    p.T_world_camera.translation() = Eigen::Vector3d(a.at(i, 1), a.at(i, 2), a.at(i, 3));
    trajectory.push_back(p);
  }
  return trajectory;
}

Eigen::Vector3d vector3_from_object(const py::handle& value, const char* name) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || a.ndim() != 1 || a.shape(0) != 3) {
    PyErr_Clear();
    bad_array(name, "3 numbers", value);
  }
  return {a.at(0), a.at(1), a.at(2)};
}

py::array_t<double> vector3_to_array(const Eigen::Vector3d& v) {
  return new_array<double>({3}, v.data());
}

py::array_t<double> pose_to_array(const Eigen::Isometry3d& pose) {
  const Eigen::Matrix<double, 4, 4, Eigen::RowMajor> m = pose.matrix();
  return new_array<double>({4, 4}, m.data());
}

py::array_t<std::uint16_t> depth_to_array(const DepthImage& image) {
  return new_array<std::uint16_t>({image.height, image.width}, image.data.data());
}

py::array_t<std::uint8_t> color_to_array(const ColorImage& image) {
  return new_array<std::uint8_t>({image.height, image.width, 3}, image.data.data());
}

py::array_t<float> vec4_to_array(const Vec4Image& image) {
  py::array_t<float> array({py::ssize_t{image.height}, py::ssize_t{image.width}, py::ssize_t{4}});
  float* out = array.mutable_data();
  for (const Eigen::Vector4f& v : image.data) out = std::copy_n(v.data(), 4, out);
  return array;
}

py::array_t<double> imu_to_array(const std::vector<ImuSample>& samples) {
  py::array_t<double> array({static_cast<py::ssize_t>(samples.size()), py::ssize_t{7}});
  double* out = array.mutable_data();
  for (const ImuSample& s : samples) {
    *out++ = s.timestamp;
    out = std::copy_n(s.gyro.data(), 3, out);
    out = std::copy_n(s.accel.data(), 3, out);
  }
  return array;
}

py::array_t<double> trajectory_to_array(const Trajectory& trajectory) {
  py::array_t<double> array({static_cast<py::ssize_t>(trajectory.size()), py::ssize_t{8}});
  double* out = array.mutable_data();
  for (const StampedPose& p : trajectory) {
    const Eigen::Quaterniond q(p.T_world_camera.linear());
    *out++ = p.timestamp;
    out = std::copy_n(p.T_world_camera.translation().data(), 3, out);
    for (const double v : {q.x(), q.y(), q.z(), q.w()}) *out++ = v;
  }
  return array;
}

}  // namespace imufusion::python
