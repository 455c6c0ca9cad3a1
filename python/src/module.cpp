// gpisvdb._core: the engine for Python (docs/python.md). Models from numpy arrays or files, the band with its
// channels as numpy views, the tasks on a band, .vdb output. The package gpisvdb (python/gpisvdb/__init__.py)
// re-exports everything here.
// The module is bound in parts (bindings.h): the exceptions here, model_bindings.cpp, band_bindings.cpp, task_bindings.cpp.
#include <pybind11/pybind11.h>

#include <new>
#include <string>

#include <openvdb/openvdb.h>

#include "bindings.h"
#include "gpisvdb/app/parameter_names.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/spectrum.h"

namespace gpisvdb::python {

namespace {

PyObject* gError = nullptr;
PyObject* gInputError = nullptr;
PyObject* gParameterError = nullptr;
PyObject* gMemoryLimitError = nullptr;
PyObject* gOutputError = nullptr;

std::string pythonMessage(const Error& error) { return app::frontEndMessage(error, app::FrontEnd::Python); }

void translateErrors(std::exception_ptr p) {
    try {
        if (p) std::rethrow_exception(p);
    } catch (const Cancelled&) {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
    } catch (const MemoryLimitError& e) {
        PyErr_SetString(gMemoryLimitError, pythonMessage(e).c_str());
    } catch (const ParameterError& e) {
        PyErr_SetString(gParameterError, pythonMessage(e).c_str());
    } catch (const InputError& e) {
        PyErr_SetString(gInputError, pythonMessage(e).c_str());
    } catch (const OutputError& e) {
        PyErr_SetString(gOutputError, pythonMessage(e).c_str());
    } catch (const Error& e) {
        PyErr_SetString(gError, pythonMessage(e).c_str());
    } catch (const std::bad_alloc&) {
        PyErr_SetString(PyExc_MemoryError, "out of memory");
    }
}

/// gpisvdb.Error and its subclasses, and the translation of the engine's exceptions into them.
void bindErrors(py::module_& m) {
    // gpisvdb.Error is a RuntimeError; parameter and input errors are also ValueErrors.
    gError = PyErr_NewExceptionWithDoc("gpisvdb.Error", "Base of every error gpisvdb reports.", PyExc_RuntimeError, nullptr);
    py::tuple inputBases = py::make_tuple(py::handle(gError), py::handle(PyExc_ValueError));
    gInputError = PyErr_NewExceptionWithDoc(
        "gpisvdb.InputError", "The input (a file or an array) is missing, malformed or holds unusable data.", inputBases.ptr(), nullptr);
    gParameterError = PyErr_NewExceptionWithDoc(
        "gpisvdb.ParameterError", "A parameter is out of its valid range; the message names it and the range.", inputBases.ptr(), nullptr);
    gMemoryLimitError = PyErr_NewExceptionWithDoc(
        "gpisvdb.MemoryLimitError",
        "The work would need more memory than max_memory allows; refused before allocating. The message names the "
        "voxel size (or other parameter) that would fit.",
        gParameterError, nullptr);
    gOutputError = PyErr_NewExceptionWithDoc("gpisvdb.OutputError", "An output file could not be written.", gError, nullptr);
    m.attr("Error") = py::handle(gError);
    m.attr("InputError") = py::handle(gInputError);
    m.attr("ParameterError") = py::handle(gParameterError);
    m.attr("MemoryLimitError") = py::handle(gMemoryLimitError);
    m.attr("OutputError") = py::handle(gOutputError);
    py::register_exception_translator(&translateErrors);
}

}  // namespace

}  // namespace gpisvdb::python

PYBIND11_MODULE(_core, m) {
    using namespace gpisvdb::python;
    openvdb::initialize();
    m.doc() = "The gpisvdb engine (C++); use the package gpisvdb, which re-exports it.";
    m.attr("__version__") = GPISVDB_VERSION;
    // The band-voxel budget of `gpisvdb spectrum` and `gpisvdb regress` (docs/spectrum.md#budget), for band(max_voxels=…)
    m.attr("EIGEN_MAX_VOXELS") = gpisvdb::kEigenMaxBandVoxels;

    bindErrors(m);
    bindModel(m);
    bindBand(m);
}
