// gpisvdb.Model (docs/python.md): a GPIS from numpy arrays or a file, evaluated at points, and the queries on the
// model itself (rays, a mesh's collision).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/output/occupancy.h"
#include "gpisvdb/tasks/collision.h"
#include "gpisvdb/tasks/ray_query.h"
#include "work.h"

using namespace pybind11::literals;

namespace gpisvdb::python {

namespace {

ModelOptions modelOptions(double sigma, double smoothing, double noiseSmoothing, double merge, double beta, bool exact,
                          const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset,
                          double labelNoise) {
    ModelOptions o;
    o.sigmaRel = sigma;
    o.smoothingRel = smoothing;
    o.noiseSmoothing = noiseSmoothing;
    o.mergeRel = merge;
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
    if (m.loaded->input.normalsFlipped && PyErr_WarnEx(PyExc_UserWarning, kNormalsFlippedNote, 1) != 0)
        throw py::error_already_set();  // warnings turned into errors
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
        throw InputError("F has " + std::to_string(f.shape(0)) + " triangles, more than the " + std::to_string(kMaxInputSamples) +
                         " an input may hold");
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
    double *pm = mean.mutable_data(), *pg = grad.mutable_data(), *pc = cov.mutable_data(), *pmu = mu.mutable_data(), *pT = T.mutable_data(),
           *pin = inside.mutable_data();
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
    return py::dict("mean"_a = mean, "gradient"_a = grad, "covariance"_a = cov, "mu"_a = mu, "T"_a = T, "p_inside"_a = inside);
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

}  // namespace

void bindModel(py::module_& m) {
    py::class_<Model>(m, "Model", R"doc(A Gaussian process implicit surface: at every point x, (phi(x), grad phi(x)) is Gaussian.

Model(V, F, sigma=0.5, smoothing=0.4, noise_smoothing=1.2, merge=1.0, beta=6.0, exact=False, model='winding', labels=None,
      training_points=300, training_offset=0.5, label_noise=0.05, threads=0)

A triangle soup with Gaussian vertex noise (paper App. B). V: n x 3 vertex positions (world units, any real
dtype), F: m x 3 vertex indices (integer dtype), counter-clockwise seen from outside.

Parameters (as the command line's flags; docs/python.md):
  sigma            vertex noise std, relative to the length scale l (mean edge length) (> 0)
  smoothing        kernel smoothing s, relative to l (regression: to the training spacing) (> 0)
  noise_smoothing  winding: s is at least this x the samples' median position std (>= 0; 0: smoothing x l alone)
  merge            winding: where samples are denser than s (s > l), one Gaussian dipole per cell of this x s (>= 0; 0: never)
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
        .def(py::init([](py::handle V, py::handle F, double sigma, double smoothing, double noiseSmoothing, double merge, double beta,
                         bool exact, const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset,
                         double labelNoise, int threads) {
                 const ModelOptions o = modelOptions(sigma, smoothing, noiseSmoothing, merge, beta, exact, model, labels, trainingPoints,
                                                     trainingOffset, labelNoise);
                 return makeModel(soupInput(V, F), o, threads);
             }),
             "V"_a, "F"_a, py::kw_only(), "sigma"_a = kDefaultSigmaRel, "smoothing"_a = kDefaultSmoothingRel,
             "noise_smoothing"_a = kNoiseSmoothing, "merge"_a = kDefaultMergeRel, "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false,
             "model"_a = "winding", "labels"_a = py::none(), "training_points"_a = TrainingOptions{}.surfacePoints,
             "training_offset"_a = TrainingOptions{}.offsetRelative, "label_noise"_a = RegressionGpisOptions{}.labelNoise, "threads"_a = 0)
        .def_static(
            "from_cloud",
            [](py::handle P, py::handle N, py::object sigma, py::object area, double smoothing, double noiseSmoothing, double merge,
               double beta, bool exact, const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset,
               double labelNoise, int threads) {
                double rel;
                py::object perPoint;
                splitCloudSigma(sigma, rel, perPoint);
                const ModelOptions o = modelOptions(rel, smoothing, noiseSmoothing, merge, beta, exact, model, labels, trainingPoints,
                                                    trainingOffset, labelNoise);
                return makeModel(cloudInput(P, N, perPoint, area), o, threads);
            },
            "P"_a, "N"_a, py::kw_only(), "sigma"_a = py::none(), "area"_a = py::none(), "smoothing"_a = kDefaultSmoothingRel,
            "noise_smoothing"_a = kNoiseSmoothing, "merge"_a = kDefaultMergeRel, "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false,
            "model"_a = "winding", "labels"_a = py::none(), "training_points"_a = TrainingOptions{}.surfacePoints,
            "training_offset"_a = TrainingOptions{}.offsetRelative, "label_noise"_a = RegressionGpisOptions{}.labelNoise, "threads"_a = 0,
            R"doc(A model of an oriented point cloud with per-point uncertainty (docs/model.md).

P: n x 3 positions (world units), N: n x 3 outward normals (any length > 0; normalised).
sigma: a number, the position std relative to the length scale l (sqrt(area / points) of a cloud; default 0.5);
       or an array of n absolute stds (world units), one per point, like the 7th column of an .xyz file.
area:  None (estimated from the spacing) or n areas per point (world units^2).
The other keywords as for Model(V, F, ...).)doc")
        .def_static(
            "from_file",
            [](const std::string& path, double sigma, double smoothing, double noiseSmoothing, double merge, double beta, bool exact,
               const std::string& model, py::object labels, std::size_t trainingPoints, double trainingOffset, double labelNoise,
               int threads) {
                const ModelOptions o = modelOptions(sigma, smoothing, noiseSmoothing, merge, beta, exact, model, labels, trainingPoints,
                                                    trainingOffset, labelNoise);
                InputData data;
                {
                    py::gil_scoped_release release;
                    data = readInput(path);
                }
                return makeModel(std::move(data), o, threads);
            },
            "path"_a, py::kw_only(), "sigma"_a = kDefaultSigmaRel, "smoothing"_a = kDefaultSmoothingRel,
            "noise_smoothing"_a = kNoiseSmoothing, "merge"_a = kDefaultMergeRel, "beta"_a = BarnesHutOptions{}.beta, "exact"_a = false,
            "model"_a = "winding", "labels"_a = py::none(), "training_points"_a = TrainingOptions{}.surfacePoints,
            "training_offset"_a = TrainingOptions{}.offsetRelative, "label_noise"_a = RegressionGpisOptions{}.labelNoise, "threads"_a = 0,
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
        .def_property_readonly(
            "length_scale", [](const Model& m) { return m.loaded->input.samples.lengthScale; },
            "l: mean edge length (soup) or sqrt(area / points) (cloud), world units")
        .def_property_readonly(
            "sigma", [](const Model& m) { return m.loaded->input.sigma; }, "absolute noise std sigma, world units")
        .def_property_readonly(
            "smoothing", [](const Model& m) { return m.loaded->smoothing; }, "absolute kernel smoothing s, world units")
        .def_property_readonly(
            "samples", [](const Model& m) { return m.loaded->input.samples.size(); }, "samples: triangles (soup) or points (cloud) used")
        .def_property_readonly(
            "model_samples", [](const Model& m) { return m.loaded->modelSamples; },
            "the samples, or the Gaussian dipoles they were merged into (merge; docs/math.md#merging), that the model sums")
        .def_property_readonly(
            "skipped", [](const Model& m) { return m.loaded->input.degenerateSkipped; }, "zero-area triangles left out")
        .def_property_readonly("is_soup", [](const Model& m) { return m.loaded->input.isSoup; })
        .def_property_readonly(
            "normals_flipped", [](const Model& m) { return m.loaded->input.normalsFlipped; },
            "the input's normals pointed inward and were flipped (docs/math.md#orientation)")
        .def_property_readonly("kind", [](const Model& m) { return m.options.kind == ModelKind::Regression ? "regression" : "winding"; })
        .def_property_readonly(
            "iso", [](const Model& m) { return m.loaded->model->naturalIso(); },
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
}

}  // namespace gpisvdb::python
