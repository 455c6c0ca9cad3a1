#pragma once
// numpy in and out for the module: every array from the caller is checked (shape, dtype, finiteness) and
// converted to the engine's types, or refused with gpisvdb::InputError naming the argument, so that no input can
// crash the interpreter. Arrays out are either fresh copies or read-only views on a Band (no copy of a channel).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <string>
#include <vector>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/types.h"

namespace gpisvdb::python {

namespace py = pybind11;

/// "float64", "int32", ...
inline std::string dtypeName(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

/// Any array-like (list, tuple, numpy array of any layout) as an array; refuses objects numpy cannot read as one.
inline py::array asArray(py::handle obj, const char* name) {
    if (obj.is_none()) throw InputError(std::string(name) + " is None, expected an array");
    py::array a = py::array::ensure(obj);
    if (!a) {
        PyErr_Clear();
        throw InputError(std::string(name) + " is not an array (got " + std::string(py::str(py::type::of(obj).attr("__name__"))) + ")");
    }
    return a;
}

/// Real numbers as float64, C-contiguous (converted from any integer or float dtype and any strides); bool,
/// complex, object and string dtypes are refused.
inline py::array_t<double, py::array::c_style | py::array::forcecast> realArray(py::handle obj, const char* name) {
    const py::array a = asArray(obj, name);
    const char kind = a.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
        throw InputError(std::string(name) + " must hold real numbers, got dtype " + dtypeName(a));
    return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
}

inline std::string shapeText(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

/// An n × 3 array of finite real numbers (one point per row, world units). With `single`, a flat triple is
/// accepted as one point. Refuses NaN and infinities, naming the row.
inline std::vector<Vec3d> points3(py::handle obj, const char* name, bool single = false, std::size_t minRows = 1) {
    const auto a = realArray(obj, name);
    const bool flat = single && a.ndim() == 1 && a.shape(0) == 3;
    if (!flat && !(a.ndim() == 2 && a.shape(1) == 3))
        throw InputError(std::string(name) + " must be an n x 3 array" + (single ? " (or one point x, y, z)" : "") + ", got shape " +
                         shapeText(a));
    const std::size_t n = flat ? 1 : std::size_t(a.shape(0));
    if (n < minRows)
        throw InputError(std::string(name) + " needs at least " + std::to_string(minRows) + (minRows == 1 ? " point" : " points") +
                         ", got " + std::to_string(n));
    const double* p = a.data();
    std::vector<Vec3d> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        out[i] = Vec3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
        if (!out[i].allFinite()) throw InputError(std::string(name) + "[" + std::to_string(i) + "] is not finite (NaN or infinity)");
    }
    return out;
}

/// A vector of n finite real numbers (shape (n,)); `positive` also refuses values ≤ 0.
inline std::vector<double> values1(py::handle obj, const char* name, std::size_t n, bool positive = false, bool nonNegative = false) {
    const auto a = realArray(obj, name);
    if (!(a.ndim() == 1 && std::size_t(a.shape(0)) == n))
        throw InputError(std::string(name) + " must have shape (" + std::to_string(n) + ",), got " + shapeText(a));
    std::vector<double> out(a.data(), a.data() + n);
    for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(out[i])) throw InputError(std::string(name) + "[" + std::to_string(i) + "] is not finite (NaN or infinity)");
        if (positive && !(out[i] > 0)) throw InputError(std::string(name) + "[" + std::to_string(i) + "] must be > 0");
        if (nonNegative && !(out[i] >= 0)) throw InputError(std::string(name) + "[" + std::to_string(i) + "] must be >= 0");
    }
    return out;
}

/// A per-voxel float array of shape (n,) or (n, components) as the engine's flat float vector (row-major).
inline std::vector<float> channel(py::handle obj, const char* name, std::size_t n, int components) {
    const auto a = realArray(obj, name);
    const bool ok = components == 1 ? (a.ndim() == 1 && std::size_t(a.shape(0)) == n)
                                    : (a.ndim() == 2 && std::size_t(a.shape(0)) == n && a.shape(1) == components);
    if (!ok)
        throw InputError(std::string(name) + " must have shape (" + std::to_string(n) +
                         (components == 1 ? ",)" : ", " + std::to_string(components) + ")") + " (one row per band voxel), got " +
                         shapeText(a));
    std::vector<float> out(n * std::size_t(components));
    for (std::size_t i = 0; i < out.size(); ++i) {
        if (!std::isfinite(a.data()[i]))
            throw InputError(std::string(name) + ": value " + std::to_string(i / std::size_t(components)) +
                             " is not finite (NaN or infinity)");
        out[i] = float(a.data()[i]);
    }
    return out;
}

/// A read-only numpy view on memory owned by `owner` (kept alive by the array): no copy.
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides, py::handle owner) {
    py::array_t<T> a(std::move(shape), std::move(strides), data, owner);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return std::move(a);
}

/// A fresh numpy array holding a copy of `v` (shape (n,) or (n, components)).
template <class T, class U>
py::array copyOf(const std::vector<U>& v, int components = 1) {
    const py::ssize_t n = py::ssize_t(v.size()) / components;
    py::array_t<T> a(components == 1 ? std::vector<py::ssize_t>{n} : std::vector<py::ssize_t>{n, components});
    T* out = a.mutable_data();
    for (std::size_t i = 0; i < v.size(); ++i) out[i] = T(v[i]);
    return std::move(a);
}

}  // namespace gpisvdb::python
