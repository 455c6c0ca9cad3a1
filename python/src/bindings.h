#pragma once
// What the parts of gpisvdb._core share (docs/python.md): the Model and Band objects Python holds, and one bind
// function per part. module.cpp binds the exceptions, defines the module and calls the others: model_bindings.cpp,
// band_bindings.cpp and task_bindings.cpp each bind one part.
#include <pybind11/pybind11.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>

#include "gpisvdb/app/band_job.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/model/load_model.h"

namespace gpisvdb::python {

namespace py = pybind11;

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// A report of the application layer (app/) as the dict Python's json module makes of it: the same keys and values
/// as the command line's JSON file.
inline py::dict reportDict(const nlohmann::json& report) {
    return py::module_::import("json").attr("loads")(report.dump()).cast<py::dict>();
}

// Model

struct Model {
    std::shared_ptr<const LoadedModel> loaded;
    ModelOptions options;
    std::string source;  ///< the file, or "numpy"
};

struct PyBand {
    app::BandJob job;  ///< the band, its model and settings (app/band_job.h), as the command line builds them

    const Band& band() const { return job.result.band; }
    /// Memory left to a task beside the band (as the command line budgets it).
    double taskBytes() const { return std::max(1.0, job.maxMemory - double(band().size()) * band().bytesPerVoxel()); }
};

/// The Model class: construction from arrays or files, evaluate, query_rays, collision (model_bindings.cpp).
void bindModel(py::module_& m);
/// The Band class with its per-voxel arrays and write_vdb, and gpisvdb.band() (band_bindings.cpp).
void bindBand(py::module_& m);
/// The tasks on a band: green, geodesic, spectrum, regress, hodge, smoothed_distance, mean_surface, surfaces
/// (task_bindings.cpp).
void bindBandTasks(py::class_<PyBand>& band);

}  // namespace gpisvdb::python
