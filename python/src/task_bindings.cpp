// The tasks on a gpisvdb.Band (docs/python.md), each as its command runs it: Green's function, geodesic distance,
// spectrum, Matérn regression, Hodge decomposition, smoothed distance, the mean surface and plausible surfaces.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "gpisvdb/app/solver_report.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/green.h"
#include "gpisvdb/tasks/hodge.h"
#include "gpisvdb/tasks/matern.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "gpisvdb/tasks/smoothed_distance.h"
#include "gpisvdb/tasks/spectrum.h"
#include "work.h"

using namespace pybind11::literals;

namespace gpisvdb::python {

namespace {

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

/// The command line's `solver` section (app::solverReport), with `converged`: Python returns a solve short of its
/// tolerance rather than raising.
py::dict solverInfo(const PcgResult& r, const PcgOptions& options) {
    nlohmann::json report = app::solverReport(r, options);
    report["converged"] = r.converged;
    return reportDict(report);
}

py::dict green(const PyBand& b, py::handle source, double tolerance, int maxIterations, const std::string& preconditioner, int threads,
               py::object progress) {
    const Vec3d y = points3(source, "source", true).front();
    const PcgOptions po = pcgOptions(tolerance, maxIterations, preconditioner);
    Work work(threads, std::move(progress));
    GreenResult g = work([&](const Progress& progress) {
        const LaplacianOperator L(b.band());  // IC and multigrid assemble it for their set-up
        return greensFunction(b.band(), L, y, po, progress);
    });
    return py::dict("values"_a = copyOf<float>(g.values), "source_index"_a = g.sourceIndex, "solver"_a = solverInfo(g.solver, po));
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

py::tuple spectrumTask(const PyBand& b, int k, int subspace, double tolerance, int maxRestarts, const std::string& method, int threads,
                       py::object progress) {
    EigenOptions o = eigenOptions(b, k, subspace, tolerance, maxRestarts);
    o.method = eigenMethod(method);
    Work work(threads, std::move(progress));
    EigenResult e = work([&](const Progress& progress) { return spectrum(b.band(), o, progress); });
    return py::make_tuple(py::array_t<double>(py::ssize_t(e.values.size()), e.values.data()), matrixCopy(e.vectors), eigenInfo(e));
}

py::dict regress(const PyBand& b, py::handle points, py::handle values, py::object noise, int k, double nu, std::optional<double> kappa,
                 std::optional<double> amplitude, int threads, py::object progress) {
    PointData data;
    data.position = points3(points, "points", true);
    data.value = values1(values, "values", data.position.size());
    data.noise =
        noise.is_none() ? std::vector<double>(data.position.size(), 0.0) : values1(noise, "noise", data.position.size(), false, true);
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

py::dict hodge(const PyBand& b, py::handle field, const std::string& boundary, double tolerance, int maxIterations, int threads,
               py::object progress) {
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
                    "solver"_a = solverInfo(r.solver, o.solver));
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
    return py::dict("values"_a = values,
                    "origin"_a = py::make_tuple(r.voxelSize * box.min().x(), r.voxelSize * box.min().y(), r.voxelSize * box.min().z()),
                    "voxel_size"_a = r.voxelSize, "background"_a = r.background, "tolerance"_a = r.tolerance, "mean_terms"_a = r.meanTerms);
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
    const double u = iso ? *iso : b.job.options.iso;
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

py::list surfacesTask(const PyBand& b, int count, std::uint64_t seed, int first, double beta, int threads, py::object progress) {
    if (b.job.model->trainingSize > 0)
        throw ParameterError("plausible surfaces are drawn from the winding-number model only (model='winding')");
    SurfaceDrawOptions o;
    o.count = count;
    o.seed = seed;
    o.firstDraw = first;
    o.openingRatio = beta;
    // The draws' noise, tree and fields, refused before they allocate, as the other tasks on a band
    const double need =
        SurfaceDraws::bytes(b.job.model->input.samples.size(), o) + 4.0 * double(std::max(count, 0)) * double(b.band().size());
    if (need > b.taskBytes())
        throw MemoryLimitError("plausible surfaces: " + std::to_string(count) + " draws on " + std::to_string(b.band().size()) +
                               " voxels need about " + numberText(need / 1e6) + " MB beside the band, more than the " +
                               numberText(b.taskBytes() / 1e6) + " MB left by max_memory: draw fewer at once (n, first)");
    Work work(threads, std::move(progress));
    const std::vector<SurfaceMesh> meshes = work([&](const Progress& p) {
        const SurfaceDraws draws(b.job.model->input.samples, b.job.model->smoothing, o);
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

void bindBandTasks(py::class_<PyBand>& band) {
    band.def("green", &green, "source"_a, py::kw_only(), "tolerance"_a = PcgOptions{}.tolerance,
             "max_iterations"_a = PcgOptions{}.maxIterations, "preconditioner"_a = "auto", "threads"_a = 0, "progress"_a = py::none(),
             R"doc(The Green's function of the GPIS Laplacian from a source point (x, y, z, world units; snapped to the nearest
voxel): solves L f = M delta_y by PCG (docs/operators.md), as `gpisvdb green`.
Returns {'values': (N,) float32 G(., y), 'source_index': int, 'solver': the command's report section (method,
preconditioner, iterations, restarts, relative_residual, ...) with 'converged'}. tolerance: PCG relative residual
(> 0); preconditioner 'auto' (the aggregation multigrid from 1e5 voxels, Jacobi below), 'aggregation',
'multigrid' (hypre BoomerAMG), 'jacobi' or 'ic'.)doc")
        .def("geodesic", &geodesic, "sources"_a, "targets"_a = py::none(), py::kw_only(), "stop_at_targets"_a = false, "threads"_a = 0,
             "progress"_a = py::none(),
             R"doc(Geodesic distance on the GPIS by Hamiltonian fast marching (docs/geodesic.md), as `gpisvdb geodesic`.

sources: one point (x, y, z) or k x 3 points, world units, snapped to the nearest voxels; targets: None, one point
or t x 3 points: a shortest path is traced back from each.
Returns a dict: 'distance' (N,) float64 U (world units x T^-1/2; inf where not reached), 'paths' (a list of
p_i x 3 float64 polylines, world units, target to source), 'path_length' (t,) Euclidean lengths, 'path_distance'
(t,) U at each target, 'reached_source' (t,) bool, 'source_index', 'target_index', 'reached', 'unreached'.)doc")
        .def("spectrum", &spectrumTask, "k"_a = EigenOptions{}.count, py::kw_only(), "subspace"_a = 0,
             "eigen_tolerance"_a = EigenOptions{}.tolerance, "max_restarts"_a = EigenOptions{}.maxRestarts, "method"_a = "auto",
             "threads"_a = 0, "progress"_a = py::none(),
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
        .def("smoothed_distance", &smoothedDistance, "alpha"_a, py::kw_only(), "grid_voxel_size"_a = py::none(), "padding"_a = py::none(),
             "tolerance"_a = py::none(), "brute_force"_a = false, "threads"_a = 0, "progress"_a = py::none(),
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
Returns a list of n (V (m, 3) float64 world units, F (t, 3) int32), draw first first.)doc");
}

}  // namespace gpisvdb::python
