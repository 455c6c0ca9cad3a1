#pragma once
// Dense linear-algebra aliases used across the engine (double precision unless a name says otherwise).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace gpisvdb {
using Vec3d = Eigen::Vector3d;
using Vec4d = Eigen::Vector4d;
using Mat3d = Eigen::Matrix3d;
using Mat4d = Eigen::Matrix4d;
using Mat43d = Eigen::Matrix<double, 4, 3>;
}  // namespace gpisvdb
