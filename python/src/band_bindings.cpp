// gpisvdb.Band and gpisvdb.band() (docs/python.md): the narrow band built as `gpisvdb band` builds it, its channels
// as numpy views, its report and metadata as the command line writes them, and its .vdb output.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "gpisvdb/app/band_job.h"
#include "gpisvdb/app/band_metadata.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/temporary_path.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/green.h"
#include "work.h"

using namespace pybind11::literals;

namespace gpisvdb::python {

namespace {

PyBand makeBand(const Model& m, std::optional<double> voxelSize, std::optional<double> resolutionScale, std::optional<double> maxVoxels,
                const std::string& voxelValues, std::optional<double> iso, double eta, int qmc, double maxAnisotropy,
                std::optional<double> maxMemory, int threads, py::object progress) {
    DefaultBandOptions o;
    if (voxelSize) {
        o.band.voxelSize = *voxelSize;
        if (!(o.band.voxelSize > 0) || !std::isfinite(o.band.voxelSize))
            throw ParameterError("the voxel size (voxel_size) must be finite and > 0, or None for the default (got " +
                                 numberText(o.band.voxelSize) + ")");
    }
    if (iso) o.band.iso = *iso;
    if (iso && !std::isfinite(o.band.iso)) throw ParameterError("iso must be finite");
    o.band.etaRelative = eta;
    o.band.qmcSamples = qmc;
    o.band.maxAnisotropy = maxAnisotropy;
    o.resolutionScale = resolutionScale.value_or(1.0);
    // As the command line: the budget applies to the default voxel size, and to a given resolution_scale only when
    // max_voxels is given too.
    o.maxBandVoxels = maxVoxels ? *maxVoxels : resolutionScale ? 0.0 : kDefaultMaxBandVoxels;
    if (voxelValues != "auto") o.values = voxelValuesNamed(voxelValues);
    if (maxMemory) {
        o.maxMemory = *maxMemory;
        if (!(o.maxMemory > 0) || !std::isfinite(o.maxMemory))
            throw ParameterError("max_memory must be a number of bytes > 0, or None for half the RAM");
    }
    Work work(threads, std::move(progress));
    PyBand b;
    b.job = work([&](const Progress& progress) { return app::buildBandJob(m.loaded, m.options, o, progress); });
    b.job.source = m.source;
    b.job.warnings = app::bandWarnings(b.job, app::FrontEnd::Python);
    return b;
}

/// The command line's report (app::bandReport) as a dict, with input.source (the input's path or "numpy"),
/// band.bytes_per_voxel and timings_s.band.
py::dict bandReport(const PyBand& b) {
    nlohmann::json report = app::bandReport(b.job);
    report["input"]["source"] = b.job.source;
    report["band"]["bytes_per_voxel"] = b.band().bytesPerVoxel();
    report["timings_s"] = {{"band", b.job.secondsBand}};
    return reportDict(report);
}

/// File metadata, as the command line writes it (app/band_metadata.h); `mesh` reads 'iso'.
openvdb::MetaMap bandMetadata(const PyBand& b, const VdbWriteOptions& vdb) {
    return app::bandMetadata({"python: gpisvdb.band", b.job.source, ""}, b.job.modelOptions, *b.job.model, b.job.options, b.job.resolution,
                             b.job.budgeted, b.job.result, vdb);
}

/// Writes under a temporary name beside `path` and renames it into place, so that an error or a Ctrl-C leaves
/// no file (nor a partial one) behind.
template <class Write>
void writeAtomically(const std::string& path, Write&& write, int threads) {
    const std::string temp = temporaryPathBeside(path);
    struct Remove {
        std::string p;
        bool keep = false;
        ~Remove() {
            std::error_code e;
            if (!keep) std::filesystem::remove(p, e);
        }
    } cleanup{temp};
    Work work(threads, py::none());
    work([&](const Progress&) {
        write(temp);
        return 0;
    });
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // a Ctrl-C during the write: no file
    std::error_code ec;
    std::filesystem::rename(temp, path, ec);
    if (ec) throw OutputError(path + ": cannot rename the finished file into place: " + ec.message());
    cleanup.keep = true;
}

void writeBand(const PyBand& b, const std::string& path, bool half, bool stencils, py::object channels, py::object vectors,
               const std::string& fogName, bool nanovdb, int threads) {
    const std::size_t n = b.band().size();
    std::vector<std::string> names;
    std::vector<std::vector<float>> scalar, vector;
    std::vector<std::string> vectorNames;
    if (!channels.is_none())
        for (auto item : channels.cast<py::dict>()) {
            names.push_back(py::str(item.first));
            scalar.push_back(channel(item.second, ("channels['" + names.back() + "']").c_str(), n, 1));
        }
    if (!vectors.is_none())
        for (auto item : vectors.cast<py::dict>()) {
            vectorNames.push_back(py::str(item.first));
            vector.push_back(channel(item.second, ("vectors['" + vectorNames.back() + "']").c_str(), n, 3));
        }
    std::vector<NamedChannel> extra;
    for (std::size_t i = 0; i < names.size(); ++i) extra.push_back({names[i], &scalar[i]});
    std::vector<NamedVectorChannel> vec;
    for (std::size_t i = 0; i < vectorNames.size(); ++i) vec.push_back({vectorNames[i], &vector[i]});
    VdbWriteOptions vo;
    vo.halfFloat = half;
    vo.sellingStencils = stencils;
    vo.occupancyName = fogName;
    vo.nanoVdb = nanovdb || isNanoVdbPath(path);
    const openvdb::MetaMap meta = bandMetadata(b, vo);
    writeAtomically(
        path, [&](const std::string& temp) { writeBandVdb(b.band(), temp, meta, extra, vec, vo); }, threads);
}

}  // namespace

void bindBand(py::module_& m) {
    py::class_<PyBand> band(m, "Band", R"doc(The narrow band of a GPIS: the voxels x = h k where mu(x) > eta (docs/band.md).

Made by gpisvdb.band(model, ...). Per-voxel arrays (one row per voxel, in the band's linear order) are read-only
views on the band (no copy):
  coords (N, 3) int32 index k;  world (N, 3) float64 voxel centres h k (a new array);
  mu, mean, stddev (N,) float32;  T (N, 6) float32 as (xx, yy, zz, xy, xz, yz);  normal (N, 3) float32;
  stencil_width (N,) uint8 (max |e|_1 of the Selling stencil).
Tasks: green, geodesic, spectrum, regress, hodge, smoothed_distance, mean_surface; output: write_vdb.)doc");
    band.def("__len__", [](const PyBand& b) { return b.band().size(); })
        .def_property_readonly(
            "size", [](const PyBand& b) { return b.band().size(); }, "number of voxels N")
        .def_property_readonly(
            "voxel_size", [](const PyBand& b) { return b.band().voxelSize; }, "h, world units")
        .def_property_readonly(
            "iso", [](const PyBand& b) { return b.job.options.iso; }, "the iso-value u the band was built at")
        .def_property_readonly(
            "mass", [](const PyBand& b) { return b.band().mass(); }, "sum of mu h^3: the expected area of the surface, world units^2")
        .def_property_readonly("report", &bandReport, "input, parameters (relative and absolute), band statistics, timings (a new dict)")
        .def_property_readonly(
            "coords",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<std::int32_t>(reinterpret_cast<const std::int32_t*>(b.coord.data()), {py::ssize_t(b.size()), 3},
                                          {py::ssize_t(sizeof(openvdb::Coord)), 4}, self);
            },
            "(N, 3) int32 index coordinates k; the voxel centre is voxel_size * k")
        .def_property_readonly(
            "world",
            [](const PyBand& pb) {
                const Band& b = pb.band();
                py::array_t<double> w({py::ssize_t(b.size()), py::ssize_t(3)});
                for (std::size_t i = 0; i < b.size(); ++i)
                    for (int d = 0; d < 3; ++d) w.mutable_data()[3 * i + std::size_t(d)] = b.voxelSize * b.coord[i][d];
                return w;
            },
            "(N, 3) float64 voxel centres, world units")
        .def_property_readonly(
            "mu",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<float>(b.mu.data(), {py::ssize_t(b.size())}, {4}, self);
            },
            "(N,) float32 surface density mu, world units^-1")
        .def_property_readonly(
            "mean",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<float>(b.mean.data(), {py::ssize_t(b.size())}, {4}, self);
            },
            "(N,) float32 gamma = E[phi]")
        .def_property_readonly(
            "stddev",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<float>(b.stddev.data(), {py::ssize_t(b.size())}, {4}, self);
            },
            "(N,) float32 std of phi")
        .def_property_readonly(
            "T",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<float>(b.T.empty() ? nullptr : b.T.front().data(), {py::ssize_t(b.size()), 6}, {24, 4}, self);
            },
            "(N, 6) float32 tangent tensor T as (xx, yy, zz, xy, xz, yz), world units^-1")
        .def_property_readonly(
            "normal",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                return view<float>(b.normal.empty() ? nullptr : b.normal.front().asPointer(), {py::ssize_t(b.size()), 3}, {12, 4}, self);
            },
            "(N, 3) float32 outward unit normal")
        .def_property_readonly(
            "stencil_width",
            [](py::object self) {
                const Band& b = self.cast<const PyBand&>().band();
                const std::uint8_t* p = b.stencil.empty() ? nullptr : &b.stencil.front().width;
                return view<std::uint8_t>(p, {py::ssize_t(b.size())}, {py::ssize_t(sizeof(VoxelStencil))}, self);
            },
            "(N,) uint8 max |e|_1 over the voxel's Selling stencil")
        .def(
            "nearest", [](const PyBand& b, py::handle point) { return nearestBandVoxel(b.band(), points3(point, "point", true).front()); },
            "point"_a, "Linear index of the band voxel nearest a world point (x, y, z).")
        .def("write_vdb", &writeBand, "path"_a, py::kw_only(), "half"_a = false, "stencils"_a = false, "channels"_a = py::none(),
             "vectors"_a = py::none(), "fog_name"_a = VdbWriteOptions{}.occupancyName, "nanovdb"_a = false, "threads"_a = 0,
             R"doc(Writes the band as an OpenVDB file, as `gpisvdb band` does (docs/band.md, "The .vdb file").

Grids mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width, the occupancy fog volume P(phi > u) named
`fog_name` ('density', what Blender and Houdini render without set-up; '' for none); with stencils=True the Selling
stencils (selling_weight_0..5, selling_offset_0..5); then `channels` (dict name -> (N,) array, e.g.
{'green': g['values']}) as float grids and `vectors` (dict name -> (N, 3) array) as vec3 grids. half=True stores
16-bit floats. nanovdb=True, or a path ending in .nvdb, writes NanoVDB instead (docs/band.md#nanovdb).
Written under a temporary name and renamed: an error or Ctrl-C leaves no file. Raises OutputError.)doc");
    bindBandTasks(band);
    band.def("__repr__", [](const PyBand& b) {
        return "<gpisvdb.Band " + std::to_string(b.band().size()) + " voxels of size " + numberText(b.band().voxelSize) + ", mass " +
               numberText(b.band().mass()) + ">";
    });

    m.def("band", &makeBand, "model"_a, py::kw_only(), "voxel_size"_a = py::none(), "resolution_scale"_a = py::none(),
          "max_voxels"_a = py::none(), "voxel_values"_a = "auto", "iso"_a = py::none(), "eta"_a = BandOptions{}.etaRelative,
          "qmc"_a = BandOptions{}.qmcSamples, "max_anisotropy"_a = BandOptions{}.maxAnisotropy, "max_memory"_a = py::none(),
          "threads"_a = 0, "progress"_a = py::none(),
          R"doc(The narrow band of the GPIS with mu, T and the Selling stencils, as `gpisvdb band` builds it (docs/band.md).

  voxel_size        h in world units (None: min(h*, 1.25 w_mu), h* = l / max stencil width, w_mu mu's width)
  resolution_scale  scales the default voxel size (> 0; below 1 is finer; 0.6 for pictures of mu without moire;
                    None: 1)
  max_voxels        band-voxel budget: a default voxel size that would make more band voxels is raised until the
                    band holds about this many (0: none; None: 4e6, or none when resolution_scale is given)
  voxel_values      'point': mu and T at the voxels' centres; 'column': their means along the voxels' axes;
                    'voxel': each voxel's own share of the expected surface (the winding model's s at least 2h);
                    'auto': column where the budget raised the voxel size above 2 w_mu,
                    else point
  iso               iso-value u of the surface phi = u (None: 0.5 winding, 0 regression)
  eta               band threshold: keep mu > eta x (median mu at the samples' voxels) (> 0)
  qmc               QMC points S for mu and T (>= 1)
  max_anisotropy    T is regularised to sqrt(lmax/lmin) <= this (>= 1)
  max_memory        refuse (MemoryLimitError) bands needing more bytes than this (None: half the RAM)
  threads           worker threads (0: all cores); the GIL is released while the band is built
  progress          None or a callable (stage: str, fraction: float), called on this thread

Ctrl-C (KeyboardInterrupt) stops the build within a fraction of a second.
Example:
  >>> band = gpisvdb.band(gpisvdb.Model.from_file('bunny.obj', sigma=1.0))
  >>> band.mu.shape, band.voxel_size, band.mass
  >>> band.write_vdb('bunny.vdb'))doc");
}

}  // namespace gpisvdb::python
