#pragma once
// Between numpy arrays and the library's types, and from a failing Result to a Python exception.
// Every array check raises ValueError naming the argument, the expected dtype and shape and the
// ones given.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Geometry>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "imufusion/result.hpp"
#include "imufusion/types.hpp"

namespace imufusion::python {

namespace py = pybind11;

/// Raw depth units per metre when a call is given none (TUM's and the synthetic sensor's).
inline constexpr double kDefaultDepthScale = 5000.0;

/// A failing Result or Status on its way to Python, where it becomes imufusion.Error (a
/// RuntimeError whose text is the error's describe() and whose `code` names the ErrorCode).
class ResultError : public std::runtime_error {
 public:
  explicit ResultError(Error error)
      : std::runtime_error(error.describe()), error_(std::move(error)) {}
  const Error& error() const { return error_; }

 private:
  Error error_;
};

/// Registers imufusion.Error in `m` and the translation of ResultError into it.
void register_error(py::module_& m);

template <typename T>
T unwrap(Result<T> result) {
  if (!result.ok()) throw ResultError(result.error());
  return std::move(result).value();
}

inline void check(const Status& status) {
  if (!status.ok()) throw ResultError(status.error());
}

/// "uint16 array of shape (480, 640)" (or the Python type of something that is no array).
std::string describe_array(const py::handle& value);

/// A depth image from a uint16 array (raw units, `depth_scale` of them per metre) or a float32 /
/// float64 array in metres (quantized at `depth_scale`; NaN, <= 0 and beyond the 16-bit range
/// become 0, no measurement), shape (H, W).
DepthImage depth_from_array(const py::handle& value, double depth_scale, const char* name);
/// A colour image from a uint8 array of shape (H, W, 3).
ColorImage color_from_array(const py::handle& value, const char* name);

/// A view over a numpy frame and the array it reads (the caller's, or a C-contiguous copy when
/// its pixels are not packed along rows); the view is valid while `array` is held.
template <typename View>
struct ArrayView {
  py::array array;
  View view;
};
/// A depth view over a uint16 (raw units, `depth_scale` per metre) or float32 / float64 (metres,
/// float64 copied to float32) array of shape (H, W); rows may be strided.
ArrayView<DepthView> depth_view_of_array(const py::handle& value, double depth_scale,
                                         const char* name);
/// A colour view over a uint8 (H, W, 3) array; rows may be strided.
ArrayView<ColorView> color_view_of_array(const py::handle& value, const char* name);
/// IMU samples from None (none), an (N, 7) float array (t, gx, gy, gz, ax, ay, az: s, rad/s,
/// m/s^2), or a sequence of ImuSample.
std::vector<ImuSample> imu_from_object(const py::handle& value, const char* name);
/// A rigid transform from a (4, 4) float array: last row (0, 0, 0, 1), orthonormal rotation
/// (within 1e-6), finite.
Eigen::Isometry3d pose_from_array(const py::handle& value, const char* name);
/// A trajectory from an (N, 8) TUM array (t tx ty tz qx qy qz qw) or a sequence of (t, 4x4).
Trajectory trajectory_from_object(const py::handle& value, const char* name);

/// A 3-vector from anything numpy reads as 3 numbers (a list, a (3,) array).
Eigen::Vector3d vector3_from_object(const py::handle& value, const char* name);

py::array_t<double> vector3_to_array(const Eigen::Vector3d& v);  // (3,)
py::array_t<double> pose_to_array(const Eigen::Isometry3d& pose);
py::array_t<std::uint16_t> depth_to_array(const DepthImage& image);
py::array_t<std::uint8_t> color_to_array(const ColorImage& image);
py::array_t<float> vec4_to_array(const Vec4Image& image);  // (H, W, 4), w = 1 where valid
py::array_t<double> imu_to_array(const std::vector<ImuSample>& samples);  // (N, 7)
py::array_t<double> trajectory_to_array(const Trajectory& trajectory);    // (N, 8), TUM order

}  // namespace imufusion::python
