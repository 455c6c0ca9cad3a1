#include "gpisvdb/model/regression_gpis.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <Eigen/Cholesky>
#include <limits>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/point_data.h"

namespace gpisvdb {

// === Training data

LabelledPoints trainingFromSamples(const Samples& samples, const TrainingOptions& o, double* spacing) {
    const std::size_t N = samples.size();
    if (N == 0) throw InputError("regression GPIS: the input has no samples");
    if (o.surfacePoints < 1)
        throw ParameterError("the training surface points (TrainingOptions::surfacePoints) must be >= 1",
                             {"TrainingOptions::surfacePoints"});
    if (!(o.offsetRelative > 0) || !std::isfinite(o.offsetRelative))
        throw ParameterError("the training label offset (TrainingOptions::offsetRelative) must be finite and > 0",
                             {"TrainingOptions::offsetRelative"});
    const std::size_t n = std::min(o.surfacePoints, N);
    // Farthest-point sampling: each new point is the sample farthest from those chosen (ties: lowest index).
    std::vector<std::size_t> chosen{0};
    std::vector<double> d2(N, std::numeric_limits<double>::infinity());
    while (chosen.size() < n) {
        const Vec3d& p = samples.position[chosen.back()];
        std::size_t best = 0;
        for (std::size_t i = 0; i < N; ++i) {
            d2[i] = std::min(d2[i], (samples.position[i] - p).squaredNorm());
            if (d2[i] > d2[best]) best = i;
        }
        chosen.push_back(best);
    }
    double area = 0;
    for (const Vec3d& w : samples.normal) area += w.norm();
    const double h = std::sqrt(area / double(n));
    if (spacing) *spacing = h;
    const double delta = o.offsetRelative * h;
    LabelledPoints t;
    for (std::size_t i : chosen) {
        const Vec3d& p = samples.position[i];
        const double len = samples.normal[i].norm();
        t.position.push_back(p);
        t.label.push_back(0.0);
        if (!(len > 0)) continue;  // no normal: the surface label only
        const Vec3d nrm = samples.normal[i] / len;
        t.position.push_back(p - delta * nrm);
        t.label.push_back(1.0);
        t.position.push_back(p + delta * nrm);
        t.label.push_back(-1.0);
    }
    return t;
}

LabelledPoints readLabelledPoints(const std::string& path) {
    PointData d = readPointData(path);
    LabelledPoints t;
    t.position = std::move(d.position);
    t.label = std::move(d.value);
    bool anyNoise = false;
    for (double s : d.noise) anyNoise = anyNoise || s > 0;
    if (anyNoise) t.noise = std::move(d.noise);
    return t;
}

// === The model

struct RegressionGpis::Impl {
    std::vector<Vec3d> x;     // training points
    Eigen::MatrixXd L;        // K = L Lᵀ
    Eigen::VectorXd weights;  // K⁻¹ (y − m₀)
    RegularizedKernel kernel;
    double scale = 0;             // a / ρ(0)
    double amplitude = 0;         // a
    double gradientVariance = 0;  // −a F₁(0) / F₀(0)
    double priorMean = 0;

    explicit Impl(double s) : kernel(s) {}

    /// B (n × 4 count): the covariances of the labels with (φ, ∇φ) at each point.
    void crossCovariance(const Vec3d* xs, std::size_t count, Eigen::MatrixXd& B) const {
        const Eigen::Index n = Eigen::Index(x.size());
        B.resize(n, Eigen::Index(4 * count));
        for (std::size_t j = 0; j < count; ++j)
            for (Eigen::Index i = 0; i < n; ++i) {
                const Vec3d y = xs[j] - x[std::size_t(i)];
                const RadialDerivatives F = kernel.at(y.squaredNorm());
                const Eigen::Index c = Eigen::Index(4 * j);
                B(i, c) = scale * F.F0;
                B(i, c + 1) = scale * F.F1 * y[0];
                B(i, c + 2) = scale * F.F1 * y[1];
                B(i, c + 3) = scale * F.F1 * y[2];
            }
    }

    void block(const Vec3d* xs, std::size_t count, ValueGradient* out) const {
        Eigen::MatrixXd B;
        crossCovariance(xs, count, B);
        // === Condition on the labels (paper Eq. 4): mean from the weights, covariance from V = L⁻¹ B
        const Eigen::RowVectorXd m = weights.transpose() * B;
        L.triangularView<Eigen::Lower>().solveInPlace(B);
        for (std::size_t j = 0; j < count; ++j) {
            const Eigen::Index c = Eigen::Index(4 * j);
            ValueGradient& z = out[j];
            z.mean = Vec4d(priorMean + m[c], m[c + 1], m[c + 2], m[c + 3]);
            const auto V = B.middleCols(c, 4);
            z.cov = -(V.transpose() * V);
            z.cov(0, 0) += amplitude;
            for (int k = 1; k < 4; ++k) z.cov(k, k) += gradientVariance;
        }
    }
};

RegressionGpis::RegressionGpis(LabelledPoints t, const RegressionGpisOptions& o) {
    if (!(o.smoothing > 0) || !std::isfinite(o.smoothing))
        throw ParameterError("regression GPIS: the kernel smoothing must be finite and > 0");
    if (!(o.amplitude > 0) || !std::isfinite(o.amplitude))
        throw ParameterError("regression GPIS: the prior variance (RegressionGpisOptions::amplitude) must be finite and > 0",
                             {"RegressionGpisOptions::amplitude"});
    if (!(o.labelNoise >= 0) || !std::isfinite(o.labelNoise))
        throw ParameterError("regression GPIS: the label noise (RegressionGpisOptions::labelNoise) must be finite and >= 0",
                             {"RegressionGpisOptions::labelNoise"});
    if (!std::isfinite(o.priorMean)) throw ParameterError("regression GPIS: the prior mean must be finite");
    const std::size_t n = t.size();
    if (n == 0) throw InputError("regression GPIS: no labelled points");
    if (t.label.size() != n || (!t.noise.empty() && t.noise.size() != n))
        throw InputError("regression GPIS: labels and points differ in number");
    for (std::size_t i = 0; i < n; ++i)
        if (!t.position[i].allFinite() || !std::isfinite(t.label[i]))
            throw InputError("regression GPIS: labelled point " + std::to_string(i + 1) + " is not finite");
    impl_ = std::make_unique<Impl>(o.smoothing);
    Impl& m = *impl_;
    const RadialDerivatives F0 = m.kernel.at(0.0);
    m.x = std::move(t.position);
    m.amplitude = o.amplitude;
    m.scale = o.amplitude / F0.F0;
    m.gradientVariance = -m.scale * F0.F1;
    m.priorMean = o.priorMean;

    // === K = [k(xᵢ, xⱼ)] + diag(noise²), factored once
    Eigen::MatrixXd K(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            for (std::size_t j = 0; j < n; ++j)
                K(Eigen::Index(i), Eigen::Index(j)) = m.scale * m.kernel.at((m.x[i] - m.x[j]).squaredNorm()).F0;
    });
    for (std::size_t i = 0; i < n; ++i) {
        const double s = t.noise.empty() ? o.labelNoise : t.noise[i];
        K(Eigen::Index(i), Eigen::Index(i)) += s * s;
    }
    Eigen::LLT<Eigen::MatrixXd> llt(K);
    if (llt.info() != Eigen::Success)
        throw Error(
            "regression GPIS: the kernel matrix of the " + std::to_string(n) +
                " labelled points is not positive definite (repeated points?): raise the label noise (RegressionGpisOptions::labelNoise)",
            {"RegressionGpisOptions::labelNoise"});
    m.L = llt.matrixL();
    Eigen::VectorXd y(static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i) y[Eigen::Index(i)] = t.label[i] - o.priorMean;
    m.weights = llt.solve(y);
}

RegressionGpis::~RegressionGpis() = default;

std::size_t RegressionGpis::trainingSize() const { return impl_->x.size(); }

std::size_t RegressionGpis::memoryBytes() const {
    const std::size_t n = impl_->x.size();
    return 8 * n * n + 32 * n;
}

ValueGradient RegressionGpis::evaluate(const Vec3d& x) const {
    ValueGradient z;
    impl_->block(&x, 1, &z);
    return z;
}

std::vector<ValueGradient> RegressionGpis::evaluate(const std::vector<Vec3d>& xs, const Progress& progress) const {
    std::vector<ValueGradient> out(xs.size());
    constexpr std::size_t kBlock = 32;    // points per triangular solve (fixed: results independent of threads)
    constexpr std::size_t kChunk = 4096;  // points between progress updates
    for (std::size_t b = 0; b < xs.size(); b += kChunk) {
        progress.checkInterrupt();
        progress.update("evaluate", double(b) / double(xs.size()));
        const std::size_t e = std::min(xs.size(), b + kChunk);
        const std::size_t blocks = (e - b + kBlock - 1) / kBlock;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t k = r.begin(); k != r.end(); ++k) {
                progress.checkInterruptAt(k, 8);
                const std::size_t first = b + k * kBlock, count = std::min(kBlock, e - first);
                impl_->block(xs.data() + first, count, out.data() + first);
            }
        });
    }
    progress.update("evaluate", 1.0);
    return out;
}

}  // namespace gpisvdb
