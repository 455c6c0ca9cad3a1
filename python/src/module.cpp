// gpisvdb._core: the engine for Python (docs/python.md). Models from numpy arrays or files, the band with its
// channels as numpy views, the tasks on a band, .vdb output. The package gpisvdb (python/gpisvdb/__init__.py)
// re-exports everything here.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arrays.h"
#include "gpisvdb/app/band_metadata.h"
#include "gpisvdb/app/parameter_names.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/model/load_model.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/occupancy.h"
#include "gpisvdb/output/temporary_path.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/green.h"
#include "gpisvdb/tasks/hodge.h"
#include "gpisvdb/tasks/matern.h"
#include "gpisvdb/tasks/smoothed_distance.h"
#include "gpisvdb/tasks/spectrum.h"
#include "gpisvdb/tasks/collision.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "gpisvdb/tasks/ray_query.h"
#include "work.h"

namespace py = pybind11;
using namespace pybind11::literals;

namespace gpisvdb::python {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// ---------------------------------------------------------------------------------------------------------------
// Errors: the engine's typed exceptions as Python classes, its Options fields named by the keyword arguments.

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

// ---------------------------------------------------------------------------------------------------------------
// Model

struct Model {
    std::shared_ptr<const LoadedModel> loaded;
    ModelOptions options;
    std::string source;  ///< the file, or "numpy"
};

ModelOptions modelOptions(double sigma, double smoothing, double noiseSmoothing, double beta, bool exact,
                          const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset,
                          double labelNoise) {
    ModelOptions o;
    o.sigmaRel = sigma;
    o.smoothingRel = smoothing;
    o.noiseSmoothing = noiseSmoothing;
    o.barnesHut.beta = beta;
    o.exact = exact;
    if (model == "winding") {
        o.kind = ModelKind::Winding;
    } else if (model == "regression") {
        o.kind = ModelKind::Regression;
    } else {
        throw ParameterError("model must be 'winding' or 'regression', got '" + model + "'");
    }
    o.training.surfacePoints = trainingPoints;
    o.training.offsetRelative = trainingOffset;
    o.labelNoise = labelNoise;
    if (!labels.is_none()) {
        if (o.kind != ModelKind::Regression) throw ParameterError("labels are for model='regression'");
        const auto a = realArray(labels, "labels");
        if (!(a.ndim() == 2 && (a.shape(1) == 4 || a.shape(1) == 5) && a.shape(0) >= 1))
            throw InputError("labels must be an n x 4 (x, y, z, label) or n x 5 (..., noise) array, got shape " + shapeText(a));
        LabelledPoints l;
        const std::size_t n = std::size_t(a.shape(0)), c = std::size_t(a.shape(1));
        for (std::size_t i = 0; i < n; ++i) {
            const double* r = a.data() + i * c;
            for (std::size_t k = 0; k < c; ++k)
                if (!std::isfinite(r[k])) throw InputError("labels[" + std::to_string(i) + "] is not finite");
            if (c == 5 && r[4] < 0) throw InputError("labels[" + std::to_string(i) + "]: the noise must be >= 0");
            l.position.emplace_back(r[0], r[1], r[2]);
            l.label.push_back(r[3]);
            if (c == 5) l.noise.push_back(r[4]);
        }
        o.labels = std::move(l);
    }
    return o;
}

Model makeModel(InputData data, const ModelOptions& options, int threads) {
    Work work(threads, py::none());
    Model m;
    m.options = options;
    m.source = data.path;
    m.loaded = work([&](const Progress&) { return std::make_shared<const LoadedModel>(loadModel(data, options)); });
    return m;
}

InputData soupInput(py::handle V, py::handle F) {
    InputData data;
    data.path = "numpy";
    TriangleSoup soup;
    soup.vertices = points3(V, "V");
    const py::array f = asArray(F, "F");
    const char kind = f.dtype().kind();
    if (kind != 'i' && kind != 'u') throw InputError("F must hold integer vertex indices, got dtype " + dtypeName(f));
    if (!(f.ndim() == 2 && f.shape(1) == 3 && f.shape(0) >= 1))
        throw InputError("F must be an m x 3 array of vertex indices (triangles), got shape " + shapeText(f));
    if (std::size_t(f.shape(0)) > kMaxInputSamples)
        throw InputError("F has " + std::to_string(f.shape(0)) + " triangles, more than the " + std::to_string(kMaxInputSamples) + " an input may hold");
    const auto idx = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(f);
    const long long nv = (long long)soup.vertices.size();
    soup.triangles.resize(std::size_t(f.shape(0)));
    for (std::size_t t = 0; t < soup.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const long long v = idx.data()[3 * t + std::size_t(k)];
            if (v < 0 || v >= nv)
                throw InputError("F[" + std::to_string(t) + "] holds vertex index " + std::to_string(v) + ", outside 0.." +
                                 std::to_string(nv - 1));
            soup.triangles[t][std::size_t(k)] = int(v);
        }
    data.soup = std::move(soup);
    return data;
}

InputData cloudInput(py::handle P, py::handle N, py::handle pointSigma, py::handle area) {
    InputData data;
    data.path = "numpy";
    PointCloud cloud;
    cloud.positions = points3(P, "P", false, 2);
    cloud.normals = points3(N, "N");
    if (cloud.normals.size() != cloud.positions.size())
        throw InputError("N must have one normal per point: " + std::to_string(cloud.positions.size()) + " points, " +
                         std::to_string(cloud.normals.size()) + " normals");
    if (cloud.positions.size() > kMaxInputSamples)
        throw InputError("P has more than the " + std::to_string(kMaxInputSamples) + " points an input may hold");
    for (std::size_t i = 0; i < cloud.normals.size(); ++i)
        if (!(cloud.normals[i].norm() > 0)) throw InputError("N[" + std::to_string(i) + "] is a zero normal");
    if (!pointSigma.is_none()) cloud.sigmas = values1(pointSigma, "sigma", cloud.positions.size(), true);
    if (!area.is_none()) cloud.areas = values1(area, "area", cloud.positions.size(), true);
    data.cloud = std::move(cloud);
    return data;
}

/// The cloud's `sigma`: a number (relative to ℓ), None (the default 0.5) or one absolute std per point.
void splitCloudSigma(py::object sigma, double& rel, py::object& perPoint) {
    rel = 0.5;
    perPoint = py::none();
    if (sigma.is_none()) return;
    if (py::isinstance<py::float_>(sigma) || py::isinstance<py::int_>(sigma)) {
        rel = sigma.cast<double>();
        return;
    }
    const py::array a = asArray(sigma, "sigma");
    if (a.ndim() == 0) {
        rel = py::float_(sigma).cast<double>();
        return;
    }
    perPoint = sigma;
}

py::dict evaluateModel(const Model& m, py::handle points, std::optional<double> iso, int qmc, int threads, py::object progress) {
    const std::vector<Vec3d> xs = points3(points, "points", true);
    const double u = iso ? *iso : m.loaded->model->naturalIso();
    if (!std::isfinite(u)) throw ParameterError("iso must be finite");
    if (qmc < 1) throw ParameterError("qmc must be >= 1 (got " + std::to_string(qmc) + ")");
    const py::ssize_t n = py::ssize_t(xs.size());
    py::array_t<double> mean(n), grad({n, py::ssize_t(3)}), cov({n, py::ssize_t(4), py::ssize_t(4)}), mu(n),
        T({n, py::ssize_t(3), py::ssize_t(3)}), inside(n);
    double *pm = mean.mutable_data(), *pg = grad.mutable_data(), *pc = cov.mutable_data(), *pmu = mu.mutable_data(),
           *pT = T.mutable_data(), *pin = inside.mutable_data();
    Work work(threads, std::move(progress));
    work([&](const Progress& progress) {
        const QmcRule rule(qmc);
        const std::vector<ValueGradient> values = m.loaded->model->evaluate(xs, progress);
        for (std::size_t i = 0; i < xs.size(); ++i) {
            progress.checkInterruptAt(i, 4096);
            const ValueGradient& v = values[i];
            pm[i] = v.mean[0];
            for (int k = 0; k < 3; ++k) pg[3 * i + std::size_t(k)] = v.mean[k + 1];
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c) pc[16 * i + std::size_t(4 * r + c)] = v.cov(r, c);
            const SurfaceDensity d = kacRice(v, u, rule);
            pmu[i] = d.mu;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) pT[9 * i + std::size_t(3 * r + c)] = d.T(r, c);
            pin[i] = insideProbability(v, u);
        }
        return 0;
    });
    return py::dict("mean"_a = mean, "gradient"_a = grad, "covariance"_a = cov, "mu"_a = mu, "T"_a = T,
                    "p_inside"_a = inside);
}

py::dict queryRaysTask(const Model& m, py::handle origins, py::handle directions, py::handle lengths, std::optional<double> step,
                       std::optional<double> iso, int threads, py::object progress) {
    const std::vector<Vec3d> o = points3(origins, "origins", true), d = points3(directions, "directions", true);
    if (d.size() != o.size()) throw InputError("directions must have as many rows as origins");
    const std::vector<double> L = values1(lengths, "lengths", o.size(), /*positive*/ true);
    RayQueryOptions options;
    options.iso = iso ? *iso : m.loaded->model->naturalIso();
    options.step = step ? *step : m.loaded->smoothing / 4;
    std::vector<Ray> rays(o.size());
    for (std::size_t i = 0; i < o.size(); ++i) rays[i] = {o[i], d[i], L[i]};
    Work work(threads, std::move(progress));
    const std::vector<RayHit> hits = work([&](const Progress& p) { return queryRays(*m.loaded->model, rays, options, p); });
    const py::ssize_t n = py::ssize_t(hits.size());
    py::array_t<double> inside(n), hit(n), expected(n), sd(n);
    for (py::ssize_t i = 0; i < n; ++i) {
        const RayHit& h = hits[std::size_t(i)];
        inside.mutable_data()[i] = h.insideAtOrigin, hit.mutable_data()[i] = h.hit;
        expected.mutable_data()[i] = h.expected, sd.mutable_data()[i] = h.stddev;
    }
    return py::dict("p_inside_origin"_a = inside, "p_hit"_a = hit, "hit_distance"_a = expected, "hit_distance_std"_a = sd,
                    "step"_a = options.step);
}

py::dict collisionTask(const Model& m, py::handle V, py::handle F, int draws, std::uint64_t seed, std::optional<double> step,
                       std::optional<double> iso, int threads, py::object progress) {
    if (m.loaded->trainingSize > 0) throw ParameterError("collision draws the winding-number model only (model='winding')");
    const InputData mesh = soupInput(V, F);
    CollisionOptions o;
    o.draws = draws, o.seed = seed;
    o.step = step ? *step : m.loaded->smoothing / 2;
    o.iso = iso ? *iso : m.loaded->model->naturalIso();
    Work work(threads, std::move(progress));
    const CollisionResult c = work([&](const Progress& p) {
        return collisionProbability(*m.loaded->model, m.loaded->input.samples, m.loaded->smoothing, mesh.soup->vertices,
                                    mesh.soup->triangles, o, p);
    });
    return py::dict("p_collision"_a = c.probability, "standard_error"_a = c.standardError, "points"_a = c.points,
                    "largest_point_p_inside"_a = c.largestInside, "step"_a = o.step);
}

// ---------------------------------------------------------------------------------------------------------------
// Band

struct PyBand {
    std::shared_ptr<const LoadedModel> model;
    ModelOptions modelOptions;
    std::string source;
    DefaultBandOptions requested;
    DefaultBand built;
    double seconds = 0;

    const Band& band() const { return built.result.band; }
    /// Memory left to a task beside the band (as the command line budgets it).
    double taskBytes() const { return std::max(1.0, built.maxMemory - double(band().size()) * band().bytesPerVoxel()); }
};

PyBand makeBand(const Model& m, std::optional<double> voxelSize, std::optional<double> resolutionScale,
                std::optional<double> maxVoxels, const std::string& voxelValues, std::optional<double> iso, double eta,
                int qmc, double maxAnisotropy, std::optional<double> maxMemory, int threads, py::object progress) {
    PyBand b;
    b.model = m.loaded;
    b.modelOptions = m.options;
    b.source = m.source;
    DefaultBandOptions& o = b.requested;
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
    if (voxelValues == "point") o.values = VoxelValues::Point;
    else if (voxelValues == "voxel") o.values = VoxelValues::Voxel;
    else throw ParameterError("voxel_values must be 'point' or 'voxel' (got '" + voxelValues + "')");
    if (maxMemory) {
        o.maxMemory = *maxMemory;
        if (!(o.maxMemory > 0) || !std::isfinite(o.maxMemory))
            throw ParameterError("max_memory must be a number of bytes > 0, or None for half the RAM");
    }
    const auto start = Clock::now();
    Work work(threads, std::move(progress));
    b.built = work([&](const Progress& progress) {
        const DefaultBandPlan first = planDefaultBand(*m.loaded->model, m.loaded->input.samples, o, progress);
        const double s = smoothingForPlan(first, *m.loaded);
        if (!(s > 0)) return buildPlannedBand(*m.loaded->model, m.loaded->input.samples, first, {}, progress);
        // The band's own model at the analysis scale (docs/band.md#coarse-voxels); the Model keeps its own.
        b.model = std::make_shared<const LoadedModel>(withSmoothing(*m.loaded, m.options, s, SmoothingSource::VoxelSize));
        const DefaultBandPlan plan = replanForSmoothing(*b.model->model, b.model->input.samples, o, first, progress);
        return buildPlannedBand(*b.model->model, b.model->input.samples, plan, {}, progress);
    });
    b.seconds = since(start);
    return b;
}

py::dict bandReport(const PyBand& b) {
    const Band& band = b.band();
    const BandStats& st = b.built.result.stats;
    const InputSamples& in = b.model->input;
    const openvdb::CoordBBox bb = band.bbox();
    const ModelOptions& mo = b.modelOptions;
    py::dict input("source"_a = b.source, "samples"_a = in.samples.size(), "length_scale"_a = in.samples.lengthScale,
                   "kind"_a = in.isSoup ? "triangle soup" : "oriented point cloud", "skipped_zero_area"_a = in.degenerateSkipped);
    py::dict parameters(
        "sigma_rel"_a = mo.sigmaRel, "sigma"_a = in.sigma, "smoothing_rel"_a = mo.smoothingRel, "smoothing"_a = b.model->smoothing,
        "noise_smoothing"_a = mo.noiseSmoothing, "smoothing_set_by"_a = smoothingSourceName(b.model->smoothingSource),
        "model"_a = mo.kind == ModelKind::Regression ? "regression" : "winding", "training_labels"_a = b.model->trainingSize,
        "iso"_a = b.built.options.iso, "eta_rel"_a = b.built.options.etaRelative, "eta"_a = st.etaAbsolute,
        "voxel_size"_a = b.built.options.voxelSize, "h_star"_a = b.built.resolution.hStar, "mu_width"_a = b.built.resolution.muWidth,
        "resolution_scale"_a = b.requested.resolutionScale, "qmc_samples"_a = b.built.options.qmcSamples,
        "voxel_values"_a = b.built.options.voxelValues ? "voxel" : "point", "max_band_voxels"_a = b.built.maxBandVoxels,
        "voxel_size_by_budget"_a = b.built.budgeted, "accuracy_voxel_size"_a = b.built.accuracyVoxelSize,
        "accuracy_voxels"_a = b.built.accuracyVoxels, "voxel_size_note"_a = voxelSizeNote(b.built),
        "beta"_a = mo.barnesHut.beta, "exact"_a = mo.exact, "max_anisotropy"_a = b.built.options.maxAnisotropy,
        "max_memory_bytes"_a = b.built.maxMemory);
    py::dict stages("model"_a = st.modelSeconds, "kac_rice"_a = st.kacRiceSeconds, "search"_a = st.searchSeconds,
                    "finish"_a = st.finishSeconds);
    py::dict bandInfo("voxels"_a = band.size(), "voxel_size"_a = band.voxelSize,
                      "bbox_voxels"_a = py::make_tuple(bb.dim().x(), bb.dim().y(), bb.dim().z()),
                      "bbox_min"_a = py::make_tuple(bb.min().x(), bb.min().y(), bb.min().z()), "mass"_a = band.mass(),
                      "max_stencil_l1"_a = st.maxStencilL1, "max_stencil_l1_at_samples"_a = b.built.resolution.maxStencilL1,
                      "evaluated_voxels"_a = st.evaluated, "bfs_levels"_a = st.levels, "regularised_voxels"_a = st.regularised,
                      "median_mu_at_samples"_a = st.medianSampleMu, "stage_seconds"_a = stages,
                      "bytes_per_voxel"_a = band.bytesPerVoxel());
    return py::dict("input"_a = input, "parameters"_a = parameters, "band"_a = bandInfo,
                    "timings_s"_a = py::dict("band"_a = b.seconds));
}

/// File metadata, as the command line writes it (app/band_metadata.h); `mesh` reads 'iso'.
openvdb::MetaMap bandMetadata(const PyBand& b, const VdbWriteOptions& vdb) {
    return app::bandMetadata({"python: gpisvdb.band", b.source, ""}, b.modelOptions, *b.model, b.built.options,
                             b.built.resolution, b.built.budgeted, b.built.result, vdb);
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
    writeAtomically(path, [&](const std::string& temp) { writeBandVdb(b.band(), temp, meta, extra, vec, vo); }, threads);
}

// ---------------------------------------------------------------------------------------------------------------
// Tasks

PcgOptions pcgOptions(double tolerance, int maxIterations, const std::string& preconditioner) {
    PcgOptions o;
    o.tolerance = tolerance;
    o.maxIterations = maxIterations;
    const auto& choices = preconditionerChoices();
    const auto chosen = std::find_if(choices.begin(), choices.end(), [&](const auto& c) { return c.first == preconditioner; });
    if (chosen == choices.end()) {
        std::string names;
        for (std::size_t i = 0; i < choices.size(); ++i)
            names += (i == 0 ? "'" : i + 1 == choices.size() ? " or '" : ", '") + choices[i].first + "'";
        throw ParameterError("preconditioner must be " + names + ", got '" + preconditioner + "'");
    }
    o.preconditioner = chosen->second;
    checkPcgOptions(o);
    return o;
}

py::dict solverInfo(const PcgResult& r) {
    return py::dict("iterations"_a = r.iterations, "relative_residual"_a = r.relativeResidual, "restarts"_a = r.restarts,
                    "converged"_a = r.converged, "preconditioner"_a = preconditionerName(r.preconditioner));
}

py::dict green(const PyBand& b, py::handle source, double tolerance, int maxIterations, const std::string& preconditioner,
               int threads, py::object progress) {
    const Vec3d y = points3(source, "source", true).front();
    const PcgOptions po = pcgOptions(tolerance, maxIterations, preconditioner);
    Work work(threads, std::move(progress));
    GreenResult g = work([&](const Progress& progress) {
        const LaplacianOperator L(b.band());  // IC and multigrid assemble it for their set-up
        return greensFunction(b.band(), L, y, po, progress);
    });
    return py::dict("values"_a = copyOf<float>(g.values), "source_index"_a = g.sourceIndex, "solver"_a = solverInfo(g.solver));
}

py::dict geodesic(const PyBand& b, py::handle sources, py::object targets, bool stopAtTargets, int threads, py::object progress) {
    const std::vector<Vec3d> src = points3(sources, "sources", true);
    const std::vector<Vec3d> tgt = targets.is_none() ? std::vector<Vec3d>{} : points3(targets, "targets", true);
    if (stopAtTargets && tgt.empty()) throw ParameterError("stop_at_targets needs at least one target");
    GeodesicOptions o;
    o.stopAtTargets = stopAtTargets;
    o.maxBytes = b.taskBytes();
    Work work(threads, std::move(progress));
    GeodesicResult g = work([&](const Progress& progress) { return geodesicDistance(b.band(), src, tgt, o, progress); });
    py::list paths;
    py::array_t<double> lengths(py::ssize_t(g.paths.size())), distances(py::ssize_t(g.paths.size()));
    py::array_t<bool> reached(py::ssize_t(g.paths.size()));
    for (std::size_t k = 0; k < g.paths.size(); ++k) {
        const GeodesicPath& p = g.paths[k];
        py::array_t<double> pts({py::ssize_t(p.points.size()), py::ssize_t(3)});
        for (std::size_t i = 0; i < p.points.size(); ++i)
            for (int d = 0; d < 3; ++d) pts.mutable_data()[3 * i + std::size_t(d)] = p.points[i][d];
        paths.append(pts);
        lengths.mutable_data()[k] = p.length;
        distances.mutable_data()[k] = p.distance;
        reached.mutable_data()[k] = p.reachedSource;
    }
    return py::dict("distance"_a = copyOf<double>(g.march.distance), "paths"_a = paths, "path_length"_a = lengths,
                    "path_distance"_a = distances, "reached_source"_a = reached, "source_index"_a = g.sourceIndex,
                    "target_index"_a = g.targetIndex, "reached"_a = g.march.accepted, "unreached"_a = g.march.unreached);
}

EigenOptions eigenOptions(const PyBand& b, int k, int subspace, double tolerance, int maxRestarts) {
    EigenOptions o;
    o.count = k;
    o.subspace = subspace;
    o.tolerance = tolerance;
    o.maxRestarts = maxRestarts;
    o.maxBytes = b.taskBytes();
    return o;
}

EigenMethod eigenMethod(const std::string& method) {
    if (method == "auto") return EigenMethod::Automatic;
    if (method == "lanczos") return EigenMethod::ShiftInvert;
    if (method == "lobpcg") return EigenMethod::Lobpcg;
    throw ParameterError("method must be 'auto', 'lanczos' or 'lobpcg', got '" + method + "'");
}

py::dict eigenInfo(const EigenResult& e) {
    return py::dict("residuals"_a = py::array_t<double>(py::ssize_t(e.residuals.size()), e.residuals.data()),
                    "orthonormality_error"_a = e.orthonormalityError, "subspace"_a = e.subspace, "restarts"_a = e.restarts,
                    "solves"_a = e.solves, "factor_nonzeros"_a = e.factorNonzeros, "ordering"_a = e.ordering,
                    "method"_a = e.method == EigenMethod::Lobpcg ? "lobpcg" : "lanczos", "iterations"_a = e.iterations);
}

/// An Eigen matrix (column-major) as a C-ordered numpy copy.
py::array matrixCopy(const Eigen::MatrixXd& m) {
    py::array_t<double> a({py::ssize_t(m.rows()), py::ssize_t(m.cols())});
    for (Eigen::Index r = 0; r < m.rows(); ++r)
        for (Eigen::Index c = 0; c < m.cols(); ++c) a.mutable_data()[r * m.cols() + c] = m(r, c);
    return std::move(a);
}

py::tuple spectrumTask(const PyBand& b, int k, int subspace, double tolerance, int maxRestarts, const std::string& method,
                       int threads, py::object progress) {
    EigenOptions o = eigenOptions(b, k, subspace, tolerance, maxRestarts);
    o.method = eigenMethod(method);
    Work work(threads, std::move(progress));
    EigenResult e = work([&](const Progress& progress) { return spectrum(b.band(), o, progress); });
    return py::make_tuple(py::array_t<double>(py::ssize_t(e.values.size()), e.values.data()), matrixCopy(e.vectors),
                          eigenInfo(e));
}

py::dict regress(const PyBand& b, py::handle points, py::handle values, py::object noise, int k, double nu,
                 std::optional<double> kappa, std::optional<double> amplitude, int threads, py::object progress) {
    PointData data;
    data.position = points3(points, "points", true);
    data.value = values1(values, "values", data.position.size());
    data.noise = noise.is_none() ? std::vector<double>(data.position.size(), 0.0)
                                 : values1(noise, "noise", data.position.size(), false, true);
    RegressionOptions ro;
    ro.kernel.nu = nu;
    if (!(nu > 0)) throw ParameterError("nu must be > 0 (or math.inf)");
    if (kappa) {
        ro.kernel.kappa = *kappa;
        if (!(ro.kernel.kappa > 0) || !std::isfinite(ro.kernel.kappa)) throw ParameterError("kappa must be finite and > 0");
    }
    if (amplitude) {
        ro.kernel.amplitude = *amplitude;
        ro.amplitudeFromData = false;
        if (!(ro.kernel.amplitude > 0) || !std::isfinite(ro.kernel.amplitude)) throw ParameterError("amplitude must be finite and > 0");
    }
    const EigenOptions eo = eigenOptions(b, k, 0, EigenOptions{}.tolerance, EigenOptions{}.maxRestarts);
    Work work(threads, std::move(progress));
    RegressionResult r = work([&](const Progress& progress) {
        const EigenResult e = spectrum(b.band(), eo, progress);
        return gpRegression(b.band(), e, data, ro, progress.interruptOnly());
    });
    return py::dict("mean"_a = copyOf<float>(r.mean), "variance"_a = copyOf<float>(r.variance),
                    "mean_at_data"_a = py::array_t<double>(py::ssize_t(r.meanAtData.size()), r.meanAtData.data()),
                    "variance_at_data"_a = py::array_t<double>(py::ssize_t(r.varianceAtData.size()), r.varianceAtData.data()),
                    "prior_mean"_a = r.priorMean, "amplitude"_a = r.amplitude, "kappa"_a = r.kappa);
}

py::dict hodge(const PyBand& b, py::handle field, const std::string& boundary, double tolerance, int maxIterations,
               int threads, py::object progress) {
    std::vector<float> V;
    if (py::isinstance<py::str>(field)) {
        const std::string p = field.cast<std::string>();
        if (p != "rotation" && p != "gradient" && p != "mixed")
            throw ParameterError("field must be an N x 3 array or one of 'rotation', 'gradient', 'mixed', got '" + p + "'");
        V = hodgePreset(b.band(), p == "rotation" ? HodgePreset::Rotation : p == "gradient" ? HodgePreset::Gradient : HodgePreset::Mixed);
    } else {
        V = channel(field, "field", b.band().size(), 3);
    }
    HodgeOptions o;
    o.solver = pcgOptions(tolerance, maxIterations, "jacobi");
    if (boundary == "neumann") o.boundary = Boundary::Neumann;
    else if (boundary == "dirichlet") o.boundary = Boundary::Dirichlet;
    else throw ParameterError("boundary must be 'neumann' or 'dirichlet', got '" + boundary + "'");
    Work work(threads, std::move(progress));
    HodgeResult r = work([&](const Progress& progress) { return hodgeDecomposition(b.band(), V, o, progress); });
    return py::dict("input"_a = copyOf<float>(V, 3), "potential"_a = copyOf<float>(r.potential),
                    "gradient"_a = copyOf<float>(r.gradient, 3), "free"_a = copyOf<float>(r.free, 3),
                    "divergence_residual"_a = r.divergenceResidual, "s_inner_product"_a = r.sInnerProduct,
                    "solver"_a = solverInfo(r.solver));
}

py::dict smoothedDistance(const PyBand& b, double alpha, std::optional<double> gridVoxelSize, std::optional<double> padding,
                          std::optional<double> tolerance, bool bruteForce, int threads, py::object progress) {
    SmoothedDistanceOptions o;
    o.alpha = alpha;
    if (!(alpha > 0) || !std::isfinite(alpha)) throw ParameterError("alpha must be finite and > 0 (world units^-1)");
    if (gridVoxelSize) {
        o.gridVoxelSize = *gridVoxelSize;
        if (!(o.gridVoxelSize > 0) || !std::isfinite(o.gridVoxelSize)) throw ParameterError("grid_voxel_size must be finite and > 0");
    }
    if (padding) {
        o.padding = *padding;
        if (!(o.padding >= 0) || !std::isfinite(o.padding)) throw ParameterError("padding must be finite and >= 0");
    }
    if (tolerance) {
        o.tolerance = *tolerance;
        if (!(o.tolerance > 0) || !std::isfinite(o.tolerance)) throw ParameterError("tolerance must be finite and > 0");
    }
    o.bruteForce = bruteForce;
    // The k-d tree, the values and the dense grid, as the command estimates them (smoothedDistanceBytes); the numpy
    // copy below (4 B per point) is made once the tree and the values are freed, so it adds nothing to that peak.
    o.maxBytes = b.taskBytes();
    Work work(threads, std::move(progress));
    SmoothedDistanceResult r = work([&](const Progress& progress) { return smoothedDistanceGrid(b.band(), o, progress); });
    const openvdb::CoordBBox box = r.grid->evalActiveVoxelBoundingBox();
    const openvdb::Coord dim = box.dim();
    py::array_t<float> values({py::ssize_t(dim.x()), py::ssize_t(dim.y()), py::ssize_t(dim.z())});
    float* out = values.mutable_data();
    const auto acc = r.grid->getConstAccessor();
    for (int i = 0; i < dim.x(); ++i)
        for (int j = 0; j < dim.y(); ++j)
            for (int k = 0; k < dim.z(); ++k)
                out[(std::size_t(i) * std::size_t(dim.y()) + std::size_t(j)) * std::size_t(dim.z()) + std::size_t(k)] =
                    acc.getValue(box.min().offsetBy(i, j, k));
    return py::dict("values"_a = values, "origin"_a = py::make_tuple(r.voxelSize * box.min().x(), r.voxelSize * box.min().y(), r.voxelSize * box.min().z()),
                    "voxel_size"_a = r.voxelSize, "background"_a = r.background, "tolerance"_a = r.tolerance,
                    "mean_terms"_a = r.meanTerms);
}

/// (V (n, 3) float64 world units, F (m, 3) int32) of a mesh.
py::tuple vertexFaceArrays(const SurfaceMesh& mesh) {
    py::array_t<double> V({py::ssize_t(mesh.vertices.size()), py::ssize_t(3)});
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
        for (int d = 0; d < 3; ++d) V.mutable_data()[3 * i + std::size_t(d)] = mesh.vertices[i][d];
    py::array_t<std::int32_t> F({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int d = 0; d < 3; ++d) F.mutable_data()[3 * t + std::size_t(d)] = mesh.triangles[t][std::size_t(d)];
    return py::make_tuple(V, F);
}

py::tuple meanSurfaceTask(const PyBand& b, std::optional<double> iso, py::object channels, int threads) {
    const double u = iso ? *iso : b.built.options.iso;
    if (!std::isfinite(u)) throw ParameterError("iso must be finite");
    const std::size_t n = b.band().size();
    // The band's grids (mean, mu, stddev, ...) and the caller's per-voxel arrays, sampled at the vertices.
    std::vector<std::string> names;
    std::vector<std::vector<float>> data;
    std::vector<int> components;
    if (channels.is_none()) {
        names = {"mu", "stddev"};
    } else {
        for (auto item : channels.cast<py::dict>()) {
            names.push_back(py::str(item.first));
            const py::array a = asArray(item.second, names.back().c_str());
            const int c = a.ndim() == 2 ? int(a.shape(1)) : 1;
            data.push_back(channel(item.second, ("channels['" + names.back() + "']").c_str(), n, c == 3 ? 3 : 1));
            components.push_back(c == 3 ? 3 : 1);
        }
    }
    Work work(threads, py::none());
    SurfaceMesh mesh = work([&](const Progress&) {
        std::vector<NamedChannel> extra;
        std::vector<NamedVectorChannel> vec;
        for (std::size_t i = 0; i < data.size(); ++i) {
            if (components[i] == 1) extra.push_back({"extra_" + names[i], &data[i]});
            else vec.push_back({"extra_" + names[i], &data[i]});
        }
        VdbWriteOptions noOccupancy;
        noOccupancy.occupancyName.clear();
        const openvdb::GridPtrVec grids = bandGrids(b.band(), extra, vec, noOccupancy);
        std::map<std::string, openvdb::GridBase::Ptr> byName;
        for (const auto& g : grids) byName[g->getName()] = g;
        const auto mean = openvdb::gridPtrCast<openvdb::FloatGrid>(byName.at("mean"));
        SurfaceMesh m = meanSurface(*mean, u);
        for (const std::string& name : names) {
            auto it = byName.find(data.empty() ? name : "extra_" + name);
            if (it == byName.end()) throw ParameterError("no band channel named '" + name + "'");
            sampleAtVertices(m, *it->second);
        }
        return m;
    });
    const py::tuple VF = vertexFaceArrays(mesh);
    py::dict values;
    for (std::size_t k = 0; k < mesh.arrayNames.size(); ++k) {
        std::string name = mesh.arrayNames[k];
        if (name.rfind("extra_", 0) == 0) name = name.substr(6);
        values[py::str(name)] = copyOf<float>(mesh.arrays[k], mesh.components[k]);
    }
    return py::make_tuple(VF[0], VF[1], values);
}

py::list surfacesTask(const PyBand& b, int count, std::uint64_t seed, int first, double beta, int threads,
                     py::object progress) {
    if (b.model->trainingSize > 0)
        throw ParameterError("plausible surfaces are drawn from the winding-number model only (model='winding')");
    SurfaceDrawOptions o;
    o.count = count;
    o.seed = seed;
    o.firstDraw = first;
    o.openingRatio = beta;
    // The draws' noise, tree and fields, refused before they allocate, as the other tasks on a band
    const double need = SurfaceDraws::bytes(b.model->input.samples.size(), o) + 4.0 * double(std::max(count, 0)) * double(b.band().size());
    if (need > b.taskBytes())
        throw MemoryLimitError("plausible surfaces: " + std::to_string(count) + " draws on " + std::to_string(b.band().size()) +
                               " voxels need about " + numberText(need / 1e6) + " MB beside the band, more than the " +
                               numberText(b.taskBytes() / 1e6) + " MB left by max_memory: draw fewer at once (n, first)");
    Work work(threads, std::move(progress));
    const std::vector<SurfaceMesh> meshes = work([&](const Progress& p) {
        const SurfaceDraws draws(b.model->input.samples, b.model->smoothing, o);
        const std::vector<std::vector<float>> fields = draws.onBand(b.band(), p);
        std::vector<SurfaceMesh> out;
        for (const auto& field : fields) {
            p.checkInterrupt();
            out.push_back(meanSurface(*drawGrid(b.band(), field), b.band().iso));
        }
        return out;
    });
    py::list out;
    for (const SurfaceMesh& mesh : meshes) out.append(vertexFaceArrays(mesh));
    return out;
}

}  // namespace

}  // namespace gpisvdb::python

// ---------------------------------------------------------------------------------------------------------------

PYBIND11_MODULE(_core, m) {
    using namespace gpisvdb;
    using namespace gpisvdb::python;
    openvdb::initialize();
    m.doc() = "The gpisvdb engine (C++); use the package gpisvdb, which re-exports it.";
    m.attr("__version__") = GPISVDB_VERSION;

    // Exceptions (gpisvdb.Error is a RuntimeError; parameter and input errors are also ValueErrors).
    gError = PyErr_NewExceptionWithDoc("gpisvdb.Error", "Base of every error gpisvdb reports.", PyExc_RuntimeError, nullptr);
    py::tuple inputBases = py::make_tuple(py::handle(gError), py::handle(PyExc_ValueError));
    gInputError = PyErr_NewExceptionWithDoc("gpisvdb.InputError",
                                            "The input (a file or an array) is missing, malformed or holds unusable data.",
                                            inputBases.ptr(), nullptr);
    gParameterError = PyErr_NewExceptionWithDoc("gpisvdb.ParameterError",
                                                "A parameter is out of its valid range; the message names it and the range.",
                                                inputBases.ptr(), nullptr);
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

    // ----------------------------------------------------------------------------------------------- Model
    py::class_<Model>(m, "Model", R"doc(A Gaussian process implicit surface: at every point x, (phi(x), grad phi(x)) is Gaussian.

Model(V, F, sigma=0.5, smoothing=0.4, noise_smoothing=1.2, beta=6.0, exact=False, model='winding', labels=None,
      training_points=300, training_offset=0.5, label_noise=0.05, threads=0)

A triangle soup with Gaussian vertex noise (paper App. B). V: n x 3 vertex positions (world units, any real
dtype), F: m x 3 vertex indices (integer dtype), counter-clockwise seen from outside.

Parameters (as the command line's flags; docs/python.md):
  sigma            vertex noise std, relative to the length scale l (mean edge length) (> 0)
  smoothing        kernel smoothing s, relative to l (regression: to the training spacing) (> 0)
  noise_smoothing  winding: s is at least this x the samples' median position std (>= 0; 0: smoothing x l alone)
  beta             Barnes-Hut accuracy: a node stands in for its samples beyond beta x its radius (> 1)
  exact            direct O(n) sums instead of Barnes-Hut
  model            'winding' (linearised winding number, surface phi = 0.5) or 'regression' (App. F, phi = 0)
  labels           regression: an n x 4 (x, y, z, label) or n x 5 (..., noise) array; None: generated
  training_points  regression: surface points kept from the input, 3 labels each
  training_offset  regression: inside/outside label offset, relative to the training spacing
  label_noise      regression: std of the labels (>= 0)
  threads          worker threads while the model is built (0: all cores)

Raises InputError (bad arrays: shape, dtype, NaN, index out of range) and ParameterError (bad parameters).

Example:
  >>> import numpy as np, gpisvdb
  >>> model = gpisvdb.Model(V, F, sigma=0.25)
  >>> model.evaluate(np.zeros((1, 3)))['mu']
)doc")
        .def(py::init([](py::handle V, py::handle F, double sigma, double smoothing, double noiseSmoothing, double beta, bool exact, const std::string& model,
                         py::object labels, std::size_t trainingPoints, double trainingOffset, double labelNoise, int threads) {
                 const ModelOptions o = modelOptions(sigma, smoothing, noiseSmoothing, beta, exact, model, labels, trainingPoints, trainingOffset, labelNoise);
                 return makeModel(soupInput(V, F), o, threads);
             }),
             "V"_a, "F"_a, py::kw_only(), "sigma"_a = kDefaultSigmaRel, "smoothing"_a = kDefaultSmoothingRel, "noise_smoothing"_a = kNoiseSmoothing, "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false,
             "model"_a = "winding", "labels"_a = py::none(), "training_points"_a = TrainingOptions{}.surfacePoints,
             "training_offset"_a = TrainingOptions{}.offsetRelative, "label_noise"_a = RegressionGpisOptions{}.labelNoise,
             "threads"_a = 0)
        .def_static(
            "from_cloud",
            [](py::handle P, py::handle N, py::object sigma, py::object area, double smoothing, double noiseSmoothing, double beta, bool exact,
               const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset, double labelNoise,
               int threads) {
                double rel;
                py::object perPoint;
                splitCloudSigma(sigma, rel, perPoint);
                const ModelOptions o = modelOptions(rel, smoothing, noiseSmoothing, beta, exact, model, labels, trainingPoints, trainingOffset, labelNoise);
                return makeModel(cloudInput(P, N, perPoint, area), o, threads);
            },
            "P"_a, "N"_a, py::kw_only(), "sigma"_a = py::none(), "area"_a = py::none(), "smoothing"_a = kDefaultSmoothingRel, "noise_smoothing"_a = kNoiseSmoothing,
            "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false, "model"_a = "winding", "labels"_a = py::none(),
            "training_points"_a = TrainingOptions{}.surfacePoints, "training_offset"_a = TrainingOptions{}.offsetRelative,
            "label_noise"_a = RegressionGpisOptions{}.labelNoise, "threads"_a = 0,
            R"doc(A model of an oriented point cloud with per-point uncertainty (docs/model.md).

P: n x 3 positions (world units), N: n x 3 outward normals (any length > 0; normalised).
sigma: a number, the position std relative to the length scale l (sqrt(area / points) of a cloud; default 0.5);
       or an array of n absolute stds (world units), one per point, like the 7th column of an .xyz file.
area:  None (estimated from the spacing) or n areas per point (world units^2).
The other keywords as for Model(V, F, ...).)doc")
        .def_static(
            "from_file",
            [](const std::string& path, double sigma, double smoothing, double noiseSmoothing, double beta, bool exact, const std::string& model,
               py::object labels, std::size_t trainingPoints, double trainingOffset, double labelNoise, int threads) {
                const ModelOptions o = modelOptions(sigma, smoothing, noiseSmoothing, beta, exact, model, labels, trainingPoints, trainingOffset, labelNoise);
                InputData data;
                {
                    py::gil_scoped_release release;
                    data = readInput(path);
                }
                return makeModel(std::move(data), o, threads);
            },
            "path"_a, py::kw_only(), "sigma"_a = kDefaultSigmaRel, "smoothing"_a = kDefaultSmoothingRel, "noise_smoothing"_a = kNoiseSmoothing, "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false,
            "model"_a = "winding", "labels"_a = py::none(), "training_points"_a = TrainingOptions{}.surfacePoints,
            "training_offset"_a = TrainingOptions{}.offsetRelative, "label_noise"_a = RegressionGpisOptions{}.labelNoise,
            "threads"_a = 0,
            R"doc(A model of a file: a triangle soup (.obj .off .ply .stl .vtp), an oriented cloud (.xyz .ply .vtp) or Gaussian dipoles (.gdp), as the
command line reads it. Keywords as for Model(V, F, ...); a cloud's per-point sigma column is used where present.)doc")
        .def("evaluate", &evaluateModel, "points"_a, py::kw_only(), "iso"_a = py::none(), "qmc"_a = 512, "threads"_a = 0,
             "progress"_a = py::none(),
             R"doc(Mean and covariance of (phi, grad phi), and the Kac-Rice mu and T, at points (n x 3, world units).

iso: the level u of the surface phi = u for mu and T (None: 0.5 for the winding model, 0 for regression).
qmc: QMC points for mu and T (>= 1).
Returns a dict of float64 arrays:
  mean        (n,)       gamma = E[phi]
  gradient    (n, 3)     E[grad phi], world units^-1
  covariance  (n, 4, 4)  covariance of (phi, d/dx phi, d/dy phi, d/dz phi)
  mu          (n,)       surface density, world units^-1 (expected area per volume)
  T           (n, 3, 3)  tangent tensor, world units^-1 (trace 2 mu)
  p_inside    (n,)       P(phi > u), the probability of being inside
The same numbers as `gpisvdb evaluate`'s CSV.)doc")
        .def_property_readonly("length_scale", [](const Model& m) { return m.loaded->input.samples.lengthScale; },
                               "l: mean edge length (soup) or sqrt(area / points) (cloud), world units")
        .def_property_readonly("sigma", [](const Model& m) { return m.loaded->input.sigma; }, "absolute noise std sigma, world units")
        .def_property_readonly("smoothing", [](const Model& m) { return m.loaded->smoothing; }, "absolute kernel smoothing s, world units")
        .def_property_readonly("samples", [](const Model& m) { return m.loaded->input.samples.size(); },
                               "samples: triangles (soup) or points (cloud) used")
        .def_property_readonly("skipped", [](const Model& m) { return m.loaded->input.degenerateSkipped; },
                               "zero-area triangles left out")
        .def_property_readonly("is_soup", [](const Model& m) { return m.loaded->input.isSoup; })
        .def_property_readonly("kind", [](const Model& m) { return m.options.kind == ModelKind::Regression ? "regression" : "winding"; })
        .def_property_readonly("iso", [](const Model& m) { return m.loaded->model->naturalIso(); },
                               "the model's own surface level u (0.5 winding, 0 regression)")
        .def("query_rays", &queryRaysTask, "origins"_a, "directions"_a, "lengths"_a, py::kw_only(), "step"_a = py::none(),
             "iso"_a = py::none(), "threads"_a = 0, "progress"_a = py::none(),
             R"doc(Where rays first enter the inside phi > u, as `gpisvdb query --rays` (docs/uncertainty.md#ray-queries).
origins, directions: n x 3 (world units; directions of any length > 0), lengths: (n,) > 0. step: spacing along
the rays (None: s / 4). Returns {'p_inside_origin', 'p_hit', 'hit_distance', 'hit_distance_std': (n,), 'step'};
the distance's mean and std are given a hit (NaN without one).)doc")
        .def("collision", &collisionTask, "V"_a, "F"_a, py::kw_only(), "draws"_a = CollisionOptions{}.draws, "seed"_a = 1,
             "step"_a = py::none(), "iso"_a = py::none(), "threads"_a = 0, "progress"_a = py::none(),
             R"doc(The probability that a mesh (V: n x 3 world units, F: m x 3 indices) meets the inside phi > u, by Monte Carlo
over `draws` draws of the GPIS, as `gpisvdb query --mesh` (docs/uncertainty.md#mesh-collision); the mesh is
sampled at spacing `step` (None: s / 2). Winding-number model only. Returns {'p_collision', 'standard_error',
'points', 'largest_point_p_inside', 'step'}.)doc")
        .def("__repr__", [](const Model& m) {
            return "<gpisvdb.Model " + std::string(m.options.kind == ModelKind::Regression ? "regression" : "winding") + " of " +
                   std::to_string(m.loaded->input.samples.size()) + (m.loaded->input.isSoup ? " triangles" : " points") +
                   ", l = " + numberText(m.loaded->input.samples.lengthScale) + ", sigma = " + numberText(m.loaded->input.sigma) + ">";
        });

    // ----------------------------------------------------------------------------------------------- Band
    py::class_<PyBand>(m, "Band", R"doc(The narrow band of a GPIS: the voxels x = h k where mu(x) > eta (docs/band.md).

Made by gpisvdb.band(model, ...). Per-voxel arrays (one row per voxel, in the band's linear order) are read-only
views on the band (no copy):
  coords (N, 3) int32 index k;  world (N, 3) float64 voxel centres h k (a new array);
  mu, mean, stddev (N,) float32;  T (N, 6) float32 as (xx, yy, zz, xy, xz, yz);  normal (N, 3) float32;
  stencil_width (N,) uint8 (max |e|_1 of the Selling stencil).
Tasks: green, geodesic, spectrum, regress, hodge, smoothed_distance, mean_surface; output: write_vdb.)doc")
        .def("__len__", [](const PyBand& b) { return b.band().size(); })
        .def_property_readonly("size", [](const PyBand& b) { return b.band().size(); }, "number of voxels N")
        .def_property_readonly("voxel_size", [](const PyBand& b) { return b.band().voxelSize; }, "h, world units")
        .def_property_readonly("iso", [](const PyBand& b) { return b.built.options.iso; }, "the iso-value u the band was built at")
        .def_property_readonly("mass", [](const PyBand& b) { return b.band().mass(); },
                               "sum of mu h^3: the expected area of the surface, world units^2")
        .def_property_readonly("report", &bandReport, "input, parameters (relative and absolute), band statistics, timings (a new dict)")
        .def_property_readonly("coords", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<std::int32_t>(reinterpret_cast<const std::int32_t*>(b.coord.data()), {py::ssize_t(b.size()), 3},
                                      {py::ssize_t(sizeof(openvdb::Coord)), 4}, self);
        }, "(N, 3) int32 index coordinates k; the voxel centre is voxel_size * k")
        .def_property_readonly("world", [](const PyBand& pb) {
            const Band& b = pb.band();
            py::array_t<double> w({py::ssize_t(b.size()), py::ssize_t(3)});
            for (std::size_t i = 0; i < b.size(); ++i)
                for (int d = 0; d < 3; ++d) w.mutable_data()[3 * i + std::size_t(d)] = b.voxelSize * b.coord[i][d];
            return w;
        }, "(N, 3) float64 voxel centres, world units")
        .def_property_readonly("mu", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<float>(b.mu.data(), {py::ssize_t(b.size())}, {4}, self);
        }, "(N,) float32 surface density mu, world units^-1")
        .def_property_readonly("mean", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<float>(b.mean.data(), {py::ssize_t(b.size())}, {4}, self);
        }, "(N,) float32 gamma = E[phi]")
        .def_property_readonly("stddev", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<float>(b.stddev.data(), {py::ssize_t(b.size())}, {4}, self);
        }, "(N,) float32 std of phi")
        .def_property_readonly("T", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<float>(b.T.empty() ? nullptr : b.T.front().data(), {py::ssize_t(b.size()), 6}, {24, 4}, self);
        }, "(N, 6) float32 tangent tensor T as (xx, yy, zz, xy, xz, yz), world units^-1")
        .def_property_readonly("normal", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            return view<float>(b.normal.empty() ? nullptr : b.normal.front().asPointer(), {py::ssize_t(b.size()), 3}, {12, 4}, self);
        }, "(N, 3) float32 outward unit normal")
        .def_property_readonly("stencil_width", [](py::object self) {
            const Band& b = self.cast<const PyBand&>().band();
            const std::uint8_t* p = b.stencil.empty() ? nullptr : &b.stencil.front().width;
            return view<std::uint8_t>(p, {py::ssize_t(b.size())}, {py::ssize_t(sizeof(VoxelStencil))}, self);
        }, "(N,) uint8 max |e|_1 over the voxel's Selling stencil")
        .def("nearest", [](const PyBand& b, py::handle point) {
            return nearestBandVoxel(b.band(), points3(point, "point", true).front());
        }, "point"_a, "Linear index of the band voxel nearest a world point (x, y, z).")
        .def("write_vdb", &writeBand, "path"_a, py::kw_only(), "half"_a = false, "stencils"_a = false, "channels"_a = py::none(),
             "vectors"_a = py::none(), "fog_name"_a = VdbWriteOptions{}.occupancyName, "nanovdb"_a = false, "threads"_a = 0,
             R"doc(Writes the band as an OpenVDB file, as `gpisvdb band` does (docs/band.md, "The .vdb file").

Grids mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width, the occupancy fog volume P(phi > u) named
`fog_name` ('density', what Blender and Houdini render without set-up; '' for none); with stencils=True the Selling
stencils (selling_weight_0..5, selling_offset_0..5); then `channels` (dict name -> (N,) array, e.g.
{'green': g['values']}) as float grids and `vectors` (dict name -> (N, 3) array) as vec3 grids. half=True stores
16-bit floats. nanovdb=True, or a path ending in .nvdb, writes NanoVDB instead (docs/band.md#nanovdb).
Written under a temporary name and renamed: an error or Ctrl-C leaves no file. Raises OutputError.)doc")
        .def("green", &green, "source"_a, py::kw_only(), "tolerance"_a = PcgOptions{}.tolerance,
             "max_iterations"_a = PcgOptions{}.maxIterations, "preconditioner"_a = "auto", "threads"_a = 0, "progress"_a = py::none(),
             R"doc(The Green's function of the GPIS Laplacian from a source point (x, y, z, world units; snapped to the nearest
voxel): solves L f = M delta_y by PCG (docs/operators.md), as `gpisvdb green`.
Returns {'values': (N,) float32 G(., y), 'source_index': int, 'solver': {iterations, relative_residual, restarts,
converged, preconditioner}}. tolerance: PCG relative residual (> 0); preconditioner 'auto' (multigrid from 1e5
voxels, Jacobi below), 'multigrid' (hypre BoomerAMG), 'jacobi' or 'ic'.)doc")
        .def("geodesic", &geodesic, "sources"_a, "targets"_a = py::none(), py::kw_only(), "stop_at_targets"_a = false,
             "threads"_a = 0, "progress"_a = py::none(),
             R"doc(Geodesic distance on the GPIS by Hamiltonian fast marching (docs/geodesic.md), as `gpisvdb geodesic`.

sources: one point (x, y, z) or k x 3 points, world units, snapped to the nearest voxels; targets: None, one point
or t x 3 points: a shortest path is traced back from each.
Returns a dict: 'distance' (N,) float64 U (world units x T^-1/2; inf where not reached), 'paths' (a list of
p_i x 3 float64 polylines, world units, target to source), 'path_length' (t,) Euclidean lengths, 'path_distance'
(t,) U at each target, 'reached_source' (t,) bool, 'source_index', 'target_index', 'reached', 'unreached'.)doc")
        .def("spectrum", &spectrumTask, "k"_a = EigenOptions{}.count, py::kw_only(), "subspace"_a = 0,
             "eigen_tolerance"_a = EigenOptions{}.tolerance, "max_restarts"_a = EigenOptions{}.maxRestarts,
             "method"_a = "auto", "threads"_a = 0, "progress"_a = py::none(),
             R"doc(The k lowest eigenpairs of L u = lambda M u (docs/spectrum.md), as `gpisvdb spectrum`.
Returns (values, vectors, info): values (k,) float64 ascending, world units^-2; vectors (N, k) float64,
M-orthonormal (sum u_i u_j mu h^3 = delta_ij); info: residuals, orthonormality error, solver counts, method.
method: 'auto' (Lanczos on a Cholesky factor where it fits in memory, else LOBPCG), 'lanczos' or 'lobpcg'
(multigrid-preconditioned, no factor; docs/spectrum.md#lobpcg).)doc")
        .def("regress", &regress, "points"_a, "values"_a, "noise"_a = py::none(), py::kw_only(), "k"_a = 200, "nu"_a = 1.5,
             "kappa"_a = py::none(), "amplitude"_a = py::none(), "threads"_a = 0, "progress"_a = py::none(),
             R"doc(Gaussian-process regression of scalar data on the GPIS with the Matern kernel of its k lowest eigenpairs
(docs/spectrum.md), as `gpisvdb regress`. points: m x 3 (world units, in the band), values: (m,), noise: None
(exact) or (m,) stds. nu: smoothness (> 0, math.inf for the squared exponential); kappa: length scale (world
units; None: 0.1 sqrt(mass)); amplitude: prior variance (None: the variance of the values).
Returns {'mean', 'variance': (N,) float32, 'mean_at_data', 'variance_at_data': (m,), 'prior_mean', 'amplitude', 'kappa'}.)doc")
        .def("hodge", &hodge, "field"_a, py::kw_only(), "boundary"_a = "neumann", "tolerance"_a = HodgeOptions{}.solver.tolerance,
             "max_iterations"_a = PcgOptions{}.maxIterations, "threads"_a = 0, "progress"_a = py::none(),
             R"doc(Hodge decomposition V = grad_phi psi + V_free of a vector field on the band (docs/hodge.md), as `gpisvdb hodge`.
field: an (N, 3) array (world units, one vector per voxel) or a preset 'rotation', 'gradient', 'mixed'.
Returns {'input', 'gradient', 'free': (N, 3) float32, 'potential': (N,) float32, 'divergence_residual',
's_inner_product', 'solver'}.)doc")
        .def("smoothed_distance", &smoothedDistance, "alpha"_a, py::kw_only(), "grid_voxel_size"_a = py::none(),
             "padding"_a = py::none(), "tolerance"_a = py::none(), "brute_force"_a = false, "threads"_a = 0, "progress"_a = py::none(),
             R"doc(The smoothed distance d_alpha to the GPIS (paper Eq. 31; docs/smoothed_distance.md) on a dense grid covering the
band, as `gpisvdb distance`. alpha: sharpness, world units^-1 (> 0). grid_voxel_size H (None: box / 128),
padding (None: 10 % of the box), tolerance per value (None: H / 100), all world units.
Returns {'values': (nx, ny, nz) float32 with values[i, j, k] at origin + H (i, j, k), 'origin', 'voxel_size',
'background', 'tolerance', 'mean_terms'}.)doc")
        .def("mean_surface", &meanSurfaceTask, py::kw_only(), "iso"_a = py::none(), "channels"_a = py::none(), "threads"_a = 0,
             R"doc(The mean surface gamma = u (u: the band's iso by default) as a triangle mesh, as `gpisvdb mesh`.
channels: None (samples mu and stddev) or a dict name -> (N,) or (N, 3) per-voxel array, sampled trilinearly at
the vertices. Returns (V (n, 3) float64 world units, F (m, 3) int32, {name: values at the vertices}).)doc")
        .def("surfaces", &surfacesTask, "n"_a = SurfaceDrawOptions{}.count, py::kw_only(), "seed"_a = SurfaceDrawOptions{}.seed,
             "first"_a = 0, "beta"_a = SurfaceDrawOptions{}.openingRatio, "threads"_a = 0, "progress"_a = py::none(),
             R"doc(Plausible surfaces, as `gpisvdb surfaces` (docs/uncertainty.md#plausible-surfaces): the level sets u of n draws
of the linearised GPIS (winding-number model only), gamma + J eps on the band's voxels. Draw k (k = first ...
first + n - 1) depends on (seed, k) alone. beta: the draws' Barnes-Hut opening ratio (> 1).
Returns a list of n (V (m, 3) float64 world units, F (t, 3) int32), draw first first.)doc")
        .def("__repr__", [](const PyBand& b) {
            return "<gpisvdb.Band " + std::to_string(b.band().size()) + " voxels of size " + numberText(b.band().voxelSize) +
                   ", mass " + numberText(b.band().mass()) + ">";
        });

    m.def("band", &makeBand, "model"_a, py::kw_only(), "voxel_size"_a = py::none(), "resolution_scale"_a = py::none(),
          "max_voxels"_a = py::none(), "voxel_values"_a = "point", "iso"_a = py::none(),
          "eta"_a = BandOptions{}.etaRelative, "qmc"_a = BandOptions{}.qmcSamples, "max_anisotropy"_a = BandOptions{}.maxAnisotropy,
          "max_memory"_a = py::none(), "threads"_a = 0, "progress"_a = py::none(),
          R"doc(The narrow band of the GPIS with mu, T and the Selling stencils, as `gpisvdb band` builds it (docs/band.md).

  voxel_size        h in world units (None: min(h*, 1.25 w_mu), h* = l / max stencil width, w_mu mu's width)
  resolution_scale  scales the default voxel size (> 0; below 1 is finer; 0.6 for pictures of mu without moire;
                    None: 1)
  max_voxels        band-voxel budget: a default voxel size that would make more band voxels is raised until the
                    band holds about this many (0: none; None: 4e6, or none when resolution_scale is given)
  voxel_values      'point': mu and T at the voxels' centres; 'voxel': each voxel's own share of the expected
                    surface (the winding model's s at least 2h)
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
