// Samples merged into Gaussian dipoles at the analysis scale (model/merge_samples.h, docs/math.md#merging).
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/accuracy.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/merge_samples.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

/// Points within 3 s of the unit sphere, and a few far from it.
std::vector<Vec3d> nearTheSphere(std::size_t count, double s, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    std::vector<Vec3d> xs;
    for (std::size_t i = 0; i < count; ++i) {
        const Vec3d u = test::randomUnit(rng);
        xs.push_back(i % 8 == 7 ? Vec3d(3 * u) : Vec3d((1 + 3 * s * U(rng)) * u));
    }
    return xs;
}

}  // namespace

TEST_CASE("merge samples: cells of one sample keep it to the bit", "[merge]") {
    const Samples s = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    // A cell far smaller than any two samples' distance holds one sample at most.
    const Samples m = mergeSamples(s, 1e-9 * s.lengthScale);
    REQUIRE(m.size() == s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
        CHECK(m.position[i] == s.position[i]);
        CHECK(m.normal[i] == s.normal[i]);
        CHECK(m.positionVariance[i] == s.positionVariance[i]);
        CHECK(m.normalCovariance[i].matrix() == s.normalCovariance[i].matrix());
    }
    CHECK(m.lengthScale == s.lengthScale);
}

TEST_CASE("merge samples: the vector area, the normals' covariance and the position noise's share are conserved", "[merge]") {
    for (double scale : {1e-6, 1.0, 1e6}) {
        InputData data = test::sphereCloudWithSigma(20000, 0.01, 7);
        for (Vec3d& p : data.cloud->positions) p *= scale;
        for (double& sg : data.cloud->sigmas) sg *= scale;
        const Samples s = makeSamples(data).samples;
        const Samples m = mergeSamples(s, 2 * s.lengthScale);
        INFO("scale " << scale << ": " << s.size() << " samples into " << m.size());
        CHECK(m.size() < s.size() / 2);
        Vec3d w = Vec3d::Zero(), wm = Vec3d::Zero();
        Mat3d N = Mat3d::Zero(), Nm = Mat3d::Zero();
        double area = 0, positionShare = 0, positionShareMerged = 0;
        for (std::size_t i = 0; i < s.size(); ++i) {
            w += s.normal[i], N += s.normalCovariance[i].matrix(), area += s.normal[i].norm();
            positionShare += s.positionVariance[i] * s.normal[i].squaredNorm();
        }
        for (std::size_t i = 0; i < m.size(); ++i) {
            wm += m.normal[i], Nm += m.normalCovariance[i].matrix();
            positionShareMerged += m.positionVariance[i] * m.normal[i].squaredNorm();
        }
        CHECK((wm - w).norm() <= 1e-9 * area);
        CHECK((Nm - N).norm() <= 1e-9 * N.norm());
        CHECK_THAT(positionShareMerged, Catch::Matchers::WithinRel(positionShare, 1e-9));
    }
}

TEST_CASE("merge samples: the model's mean and covariance converge to the unmerged ones at second order in the cell", "[merge]") {
    // A dense cloud (s = 4ℓ): the direct sums of the samples against those of their merged dipoles, near the surface.
    const Samples s = makeSamples(test::sphereCloudWithSigma(40000, 0.01, 3)).samples;
    const double sm = 4 * s.lengthScale;
    const std::vector<Vec3d> xs = nearTheSphere(400, sm, 5);
    const std::vector<ValueGradient> reference = DirectGpis(s, sm).evaluate(xs);
    double previous = 0;
    for (double rel : {1.0, 0.5, 0.25}) {
        const Samples m = mergeSamples(s, rel * sm);
        const ModelError e = compareModels(reference, DirectGpis(m, sm).evaluate(xs));
        INFO("cell " << rel << " s: " << m.size() << " dipoles; " << e.describe());
        CHECK(e.worst() <= 0.05 * rel * rel);
        if (previous > 0) CHECK(e.worst() <= 0.4 * previous);  // second order: ÷ 4 per halving, within noise
        previous = e.worst();
    }
}

TEST_CASE("merge samples: a cell whose vector areas cancel keeps a finite position noise", "[merge]") {
    Samples s;
    s.lengthScale = 1;
    for (double side : {1.0, -1.0}) {
        s.position.push_back(Vec3d(0.1, 0.1, 0.1 + 0.01 * side));
        s.normal.push_back(Vec3d(0, 0, side));
        s.positionVariance.push_back(0.04);
        s.normalCovariance.push_back(Sym3{0.01, 0.01, 0.01});
    }
    const Samples m = mergeSamples(s, 1);
    REQUIRE(m.size() == 1);
    CHECK(m.normal[0].norm() == 0);
    CHECK(std::isfinite(m.positionVariance[0]));
    CHECK_THAT(m.position[0].z(), Catch::Matchers::WithinAbs(0.1, 1e-15));
}

TEST_CASE("merge samples: a cell that is not finite and positive, or too small for the coordinates, is refused", "[merge]") {
    const Samples s = makeSamples(test::sphereCloudWithSigma(100, 0.01, 1)).samples;
    for (double cell : {0.0, -1.0, double(NAN), double(INFINITY), 1e-300}) CHECK_THROWS_AS(mergeSamples(s, cell), ParameterError);
}
