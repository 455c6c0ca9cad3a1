// The .vdb files we write, read back by independent readers: OpenVDB's vdb_print and Python's pyopenvdb.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <Eigen/SparseCore>
#include <map>
#include <nanovdb/util/IO.h>
#include <openvdb/openvdb.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/write_vdb.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

std::string runCapture(const std::string& cmd, int& code) {
    const std::string out = (test::scratchDir() / "capture.txt").string();
    const int status = std::system((cmd + " > " + out + " 2>&1").c_str());
    code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(out);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string writeSmallBand(Band& keep) {
    keep = test::sphereBand();
    openvdb::MetaMap meta;
    meta.insertMeta("gpisvdb_version", openvdb::StringMetadata(GPISVDB_VERSION));
    meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(1.0));
    const std::string path = (test::scratchDir() / "band.vdb").string();
    writeBandVdb(keep, path, meta);
    return path;
}

}  // namespace

TEST_CASE("output: vdb_print reads every grid of a band file", "[output]") {
    Band band;
    const std::string path = writeSmallBand(band);
    int code = 0;
    const std::string text = runCapture("vdb_print -l " + path, code);
    REQUIRE(code == 0);
    for (const char* name : {"mu", "mean", "stddev", "T_diag", "T_offdiag", "normal", "stencil_width", "density"})
        CHECK_THAT(text, Catch::Contains(std::string("Name: ") + name));
    CHECK_THAT(text, Catch::Contains("class: fog volume"));
    CHECK_THAT(text, Catch::Contains("sigma_rel: 1"));
    CHECK_THAT(text, Catch::Contains(std::to_string(band.size())));
}

TEST_CASE("output: pyopenvdb reads names, classes, creators, voxel size, value ranges and metadata", "[output]") {
    Band band;
    const std::string path = writeSmallBand(band);
    float lo = band.mu[0], hi = band.mu[0];
    for (float v : band.mu) lo = std::min(lo, v), hi = std::max(hi, v);
    const std::string script = (test::scratchDir() / "read.py").string();
    std::ofstream(script)
        << "import sys, pyopenvdb as vdb\n"
           "grids, meta = vdb.readAll(sys.argv[1])\n"
           "print('version', meta['gpisvdb_version'])\n"
           "for g in grids:\n"
           "    lo, hi = g.evalMinMax()\n"
           "    print('|'.join([g.name, g.gridClass, '%.9g' % g.transform.voxelSize()[0], str(g.activeVoxelCount()), str(lo), str(hi),\n"
           "                    g.creator, str(g.metadata.get('is_local_space'))]))\n";
    int code = 0;
    const std::string text = runCapture("/usr/bin/python3 " + script + " " + path, code);
    INFO(text);
    REQUIRE(code == 0);
    CHECK_THAT(text, Catch::Contains("version " GPISVDB_VERSION));
    std::istringstream lines(text);
    std::string line;
    int grids = 0;
    while (std::getline(lines, line)) {
        if (line.rfind("version", 0) == 0) continue;
        std::vector<std::string> f;
        std::istringstream ls(line);
        for (std::string part; std::getline(ls, part, '|');) f.push_back(part);
        REQUIRE(f.size() == 8);
        const std::string& name = f[0];
        const std::string& cls = f[1];
        const std::string& voxel = f[2];
        const std::size_t count = std::stoul(f[3]);
        ++grids;
        INFO(name);
        CHECK(std::stod(voxel) == Approx(0.08).epsilon(1e-6));
        CHECK(f[6] == "gpisvdb " GPISVDB_VERSION);
        if (name == "density") {  // the occupancy: the band, and the enclosed region as tiles of 1
            CHECK(cls == "fog volume");
            CHECK(f[7] == "False");
            CHECK(count > band.size());
            CHECK(std::stod(f[4]) >= 0.0);
            CHECK(std::stod(f[5]) == 1.0);
            continue;
        }
        CHECK(count == band.size());
        if (name == "mu") {
            CHECK(cls == "fog volume");
            CHECK(std::stod(f[4]) == Approx(lo).epsilon(1e-6));
            CHECK(std::stod(f[5]) == Approx(hi).epsilon(1e-6));
        }
    }
    CHECK(grids == 8);
}

namespace {

/// L rebuilt from a .vdb's grids alone, as docs/band.md#rebuilding-l-from-the-file tells a user to: the band is
/// mu's active voxels, h the grid's voxel size; each voxel x and term k give the two edges (x, x ± e_k) a weight
/// h λ_k(x)/2 each, and an edge that leaves the band adds to the diagonal only. Rows and columns in `order`.
Eigen::SparseMatrix<double> laplacianFromFile(const std::string& path, std::vector<openvdb::Coord>& order) {
    openvdb::io::File file(path);
    file.open();
    const auto mu = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("mu"));
    const double h = mu->voxelSize()[0];
    std::map<openvdb::Coord, int> index;
    order.clear();
    for (auto it = mu->cbeginValueOn(); it; ++it) {
        index[it.getCoord()] = int(order.size());
        order.push_back(it.getCoord());
    }
    std::vector<Eigen::Triplet<double>> entries;
    for (int k = 0; k < 6; ++k) {
        const auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("selling_weight_" + std::to_string(k)));
        const auto offset = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("selling_offset_" + std::to_string(k)));
        REQUIRE(weight->activeVoxelCount() == mu->activeVoxelCount());
        REQUIRE(offset->activeVoxelCount() == mu->activeVoxelCount());
        const auto w = weight->getConstAccessor();
        const auto e = offset->getConstAccessor();
        for (std::size_t i = 0; i < order.size(); ++i) {
            const double half = 0.5 * h * double(w.getValue(order[i]));
            const openvdb::Vec3s v = e.getValue(order[i]);
            const openvdb::Coord d(int(std::lround(v[0])), int(std::lround(v[1])), int(std::lround(v[2])));
            REQUIRE(openvdb::Vec3s(float(d[0]), float(d[1]), float(d[2])) == v);  // integer offsets, stored exactly
            for (const openvdb::Coord& y : {order[i] + d, order[i] - d}) {
                entries.emplace_back(int(i), int(i), half);
                const auto j = index.find(y);
                if (j == index.end()) continue;
                entries.emplace_back(j->second, j->second, half);
                entries.emplace_back(int(i), j->second, -half);
                entries.emplace_back(j->second, int(i), -half);
            }
        }
    }
    file.close();
    Eigen::SparseMatrix<double> L(int(order.size()), int(order.size()));
    L.setFromTriplets(entries.begin(), entries.end());
    return L;
}

}  // namespace

TEST_CASE("output: grid classes and vector types are the ones Houdini and Blender read (fog mu, normalised normal)", "[output]") {
    // No Houdini here (docs/guide.md): what its VDB nodes rely on is checked in the file instead. A fog volume
    // renders as density; a covariant-normalise vec3 is transformed as a normal; invariant vectors are left alone.
    Band band;
    const std::string path = writeSmallBand(band);
    openvdb::io::File file(path);
    file.open();
    const auto grids = file.getGrids();
    file.close();
    std::map<std::string, openvdb::GridBase::Ptr> byName;
    for (const auto& g : *grids) byName[g->getName()] = g;
    REQUIRE(byName.count("mu"));
    CHECK(byName["mu"]->getGridClass() == openvdb::GRID_FOG_VOLUME);
    CHECK(byName["mu"]->isType<openvdb::FloatGrid>());
    REQUIRE(byName.count("normal"));
    CHECK(byName["normal"]->isType<openvdb::Vec3SGrid>());
    CHECK(byName["normal"]->getVectorType() == openvdb::VEC_COVARIANT_NORMALIZE);
    for (const char* name : {"T_diag", "T_offdiag"}) {
        INFO(name);
        REQUIRE(byName.count(name));
        CHECK(byName[name]->isType<openvdb::Vec3SGrid>());
        CHECK(byName[name]->getVectorType() == openvdb::VEC_INVARIANT);
    }
}

TEST_CASE("output: the Selling grids rebuild the Laplacian from the file alone", "[output]") {
    openvdb::initialize();
    const double h = 0.05;
    const Band band = test::anisotropicBall(6, h, 6.0);
    int widest = 0;
    for (const VoxelStencil& st : band.stencil) widest = std::max<int>(widest, st.width);
    REQUIRE(widest >= 3);  // a case where offsets beyond the 6 axis neighbours matter
    const Eigen::SparseMatrix<double> reference = assembleLaplacianDouble(band);
    for (const bool half : {false, true}) {
        INFO("half floats: " << half);
        const std::string path = (test::scratchDir() / "selling.vdb").string();
        VdbWriteOptions o;
        o.sellingStencils = true;
        o.halfFloat = half;
        writeBandVdb(band, path, openvdb::MetaMap(), {}, {}, o);
        std::vector<openvdb::Coord> order;
        const Eigen::SparseMatrix<double> L = laplacianFromFile(path, order);
        REQUIRE(order.size() == band.size());
        // === Compare u^T L v in both orders for random u, v (file order mapped to the band's linear index)
        const auto acc = band.index->getConstAccessor();
        std::mt19937_64 rng(7);
        std::normal_distribution<double> gauss;
        Eigen::VectorXd u(band.size()), v(band.size()), uf(band.size()), vf(band.size());
        for (std::size_t i = 0; i < band.size(); ++i) {
            const int b = acc.getValue(order[i]);
            REQUIRE(b >= 0);
            uf[long(i)] = u[b] = gauss(rng);
            vf[long(i)] = v[b] = gauss(rng);
        }
        const double want = u.dot(reference * v), got = uf.dot(L * vf);
        // Float weights round-trip exactly; half floats keep about 3 significant digits.
        CHECK(got == Approx(want).epsilon(half ? 2e-3 : 1e-6));
        // === And L v entry by entry
        const Eigen::VectorXd lvFile = L * vf, lvRef = reference * v;
        double worst = 0;
        for (std::size_t i = 0; i < band.size(); ++i) worst = std::max(worst, std::abs(lvFile[long(i)] - lvRef[acc.getValue(order[i])]));
        CHECK(worst <= (half ? 2e-3 : 1e-6) * lvRef.lpNorm<Eigen::Infinity>());
    }
}

TEST_CASE("output: writeVdb refuses active inf or NaN values, and values a half cannot hold, writing nothing", "[output]") {
    const std::string path = (gpisvdb::test::scratchDir() / "output_nonfinite.vdb").string();
    const auto make = [](float value) {
        auto g = openvdb::FloatGrid::create(0.0f);
        g->setName("f");
        g->tree().setValue(openvdb::Coord(1, 2, 3), value);
        g->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
        return g;
    };
    const auto makeVec = [](float value) {
        auto g = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
        g->setName("v");
        g->tree().setValue(openvdb::Coord(4, 5, 6), openvdb::Vec3s(0.0f, value, 0.0f));
        return g;
    };
    openvdb::initialize();
    for (float bad :
         {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()}) {
        std::filesystem::remove(path);
        CHECK_THROWS_WITH(gpisvdb::writeVdb({make(bad)}, path, {}),
                          Catch::Contains("grid 'f': 1 active values (the first at voxel 1,2,3)"));
        CHECK_THROWS_WITH(gpisvdb::writeVdb({makeVec(bad)}, path, {}), Catch::Contains("grid 'v'"));
        CHECK_FALSE(std::filesystem::exists(path));
    }
    auto badBackground = make(1.0f);
    badBackground->tree().root().setBackground(std::numeric_limits<float>::infinity(), true);
    CHECK_THROWS_WITH(gpisvdb::writeVdb({badBackground}, path, {}), Catch::Contains("its background value"));
    // 1e5 is a fine float but a half turns it into inf: refused with --half (naming the option), written without.
    gpisvdb::VdbWriteOptions half;
    half.halfFloat = true;
    try {
        gpisvdb::writeVdb({make(1e5f)}, path, {}, half);
        FAIL("no refusal");
    } catch (const gpisvdb::ParameterError& e) {
        CHECK_THAT(e.what(), Catch::Contains("half-float range") && Catch::Contains("(VdbWriteOptions::halfFloat)"));
    }
    CHECK_FALSE(std::filesystem::exists(path));
    gpisvdb::writeVdb({make(1e5f), makeVec(2.0f)}, path, {});
    CHECK(std::filesystem::exists(path));
    gpisvdb::writeVdb({make(6e4f)}, path, {}, half);
}

TEST_CASE("output: writeBandVdb streams the grids of bandGrids and sellingGrids one at a time, and a refused grid leaves the old file",
          "[output]") {
    const Band band = test::sphereBand();
    std::vector<float> scalar(band.size()), vec(3 * band.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
        scalar[i] = i % 7 == 0 ? std::numeric_limits<float>::infinity() : float(i);  // non-finite: left inactive
        for (int d = 0; d < 3; ++d) vec[3 * i + std::size_t(d)] = float(d) - 0.5f * float(i);
    }
    const std::vector<NamedChannel> extra{{"distance", &scalar, -1.0f}};
    const std::vector<NamedVectorChannel> vectors{{"flow", &vec, openvdb::VEC_CONTRAVARIANT_RELATIVE}};
    openvdb::MetaMap meta;
    meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(0.5));
    VdbWriteOptions options;
    options.sellingStencils = true;
    const std::filesystem::path dir = test::scratchDir() / "streamed";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "band.vdb").string();
    writeBandVdb(band, path, meta, extra, vectors, options);

    // === Every grid the all-at-once path makes is in the file, with the same type, classes and active values
    openvdb::GridPtrVec expected = bandGrids(band, extra, vectors);
    const openvdb::GridPtrVec selling = sellingGrids(band);
    expected.insert(expected.end(), selling.begin(), selling.end());
    openvdb::io::File file(path);
    file.open();
    CHECK(file.readAllGridMetadata()->size() == expected.size());
    CHECK(file.getMetadata()->metaValue<double>("sigma_rel") == 0.5);
    for (const auto& want : expected) {
        INFO(want->getName());
        const openvdb::GridBase::Ptr got = file.readGrid(want->getName());
        REQUIRE(got->type() == want->type());
        CHECK(got->getGridClass() == want->getGridClass());
        CHECK(got->getVectorType() == want->getVectorType());
        CHECK(got->activeVoxelCount() == want->activeVoxelCount());
        CHECK(got->transform() == want->transform());
        if (auto f = openvdb::GridBase::grid<openvdb::FloatGrid>(got)) {
            auto w = openvdb::GridBase::grid<openvdb::FloatGrid>(want)->getConstAccessor();
            for (auto it = f->cbeginValueOn(); it; ++it) REQUIRE(*it == w.getValue(it.getCoord()));
            CHECK(f->background() == openvdb::GridBase::grid<openvdb::FloatGrid>(want)->background());
        } else {
            auto v = openvdb::GridBase::grid<openvdb::Vec3SGrid>(got);
            REQUIRE(v);
            auto w = openvdb::GridBase::grid<openvdb::Vec3SGrid>(want)->getConstAccessor();
            for (auto it = v->cbeginValueOn(); it; ++it) REQUIRE(*it == w.getValue(it.getCoord()));
        }
    }
    file.close();

    // === A grid refused part-way (the last of the band's own grids): the previous file stays, nothing else is left
    const auto before = std::filesystem::file_size(path);
    Band bad = band;
    bad.stencil[bad.size() / 2].weight[0] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS_WITH(writeBandVdb(bad, path, meta, extra, vectors, options), Catch::Contains("selling_weight_0"));
    CHECK(std::filesystem::file_size(path) == before);
    std::size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
    CHECK(files == 1);
}

TEST_CASE("output: a band whose grids were spilled writes the same file as one written from memory", "[output]") {
    Band band = test::sphereBand();
    std::vector<float> scalar(band.size()), vec(3 * band.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
        scalar[i] = i % 5 == 0 ? std::numeric_limits<float>::quiet_NaN() : 0.25f * float(i);
        for (int d = 0; d < 3; ++d) vec[3 * i + std::size_t(d)] = float(d) + 0.125f * float(i);
    }
    const std::vector<NamedChannel> extra{{"green", &scalar, 0.0f}};
    const std::vector<NamedVectorChannel> vectors{{"flow", &vec, openvdb::VEC_CONTRAVARIANT_RELATIVE}};
    openvdb::MetaMap meta;
    meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(0.5));
    const std::filesystem::path dir = test::scratchDir() / "spilled";
    for (const bool half : {false, true}) {
        INFO("half floats: " << half);
        std::filesystem::remove_all(dir);
        std::filesystem::create_directories(dir);
        VdbWriteOptions options;
        options.halfFloat = half;
        options.sellingStencils = true;
        const std::string fromMemory = (dir / "memory.vdb").string(), fromSpill = (dir / "spill.vdb").string();
        writeBandVdb(band, fromMemory, meta, extra, vectors, options);
        Band spilledBand = band;
        {
            const SpilledBandGrids spilled(spilledBand, (dir / "side.vdb").string(), options);
            CHECK(std::filesystem::exists(spilled.path()));
            const double freed = spillableChannelBytes(spilledBand);
            CHECK(freed >= 44.0 * double(band.size()));
            releaseSpilledChannels(spilledBand);
            CHECK(spillableChannelBytes(spilledBand) == 0);
            CHECK(spilledBand.mu == band.mu);
            // The channels are gone: writing from memory would read them, and is refused.
            CHECK_THROWS_WITH(writeBandVdb(spilledBand, fromSpill, meta, extra, vectors, options), Catch::Contains("spill"));
            VdbWriteOptions other = options;
            other.halfFloat = !half;
            CHECK_THROWS_AS(writeBandVdb(spilledBand, spilled, fromSpill, meta, extra, vectors, other), Error);
            writeBandVdb(spilledBand, spilled, fromSpill, meta, extra, vectors, options);
        }
        CHECK_FALSE(std::filesystem::exists(dir / "side.vdb"));  // the side file goes with its SpilledBandGrids

        // === The same grids in the same order, with the same metadata, classes and active values
        openvdb::io::File a(fromMemory), b(fromSpill);
        a.open();
        b.open();
        CHECK(b.getMetadata()->metaValue<double>("sigma_rel") == 0.5);
        const openvdb::GridPtrVecPtr ga = a.readAllGridMetadata(), gb = b.readAllGridMetadata();
        REQUIRE(ga->size() == gb->size());
        for (std::size_t k = 0; k < ga->size(); ++k) {
            const std::string name = (*ga)[k]->getName();
            INFO(name);
            REQUIRE((*gb)[k]->getName() == name);
            const openvdb::GridBase::Ptr x = a.readGrid(name), y = b.readGrid(name);
            REQUIRE(x->type() == y->type());
            CHECK(x->getGridClass() == y->getGridClass());
            CHECK(x->getVectorType() == y->getVectorType());
            CHECK(x->saveFloatAsHalf() == y->saveFloatAsHalf());
            CHECK(x->activeVoxelCount() == y->activeVoxelCount());
            CHECK(x->transform() == y->transform());
            if (auto f = openvdb::GridBase::grid<openvdb::FloatGrid>(x)) {
                auto g = openvdb::GridBase::grid<openvdb::FloatGrid>(y)->getConstAccessor();
                for (auto it = f->cbeginValueOn(); it; ++it) REQUIRE(*it == g.getValue(it.getCoord()));
            } else {
                auto v = openvdb::GridBase::grid<openvdb::Vec3SGrid>(x);
                REQUIRE(v);
                auto g = openvdb::GridBase::grid<openvdb::Vec3SGrid>(y)->getConstAccessor();
                for (auto it = v->cbeginValueOn(); it; ++it) REQUIRE(*it == g.getValue(it.getCoord()));
            }
        }
    }
}

namespace {
openvdb::GridBase::Ptr findGrid(const openvdb::GridPtrVec& grids, const std::string& name) {
    for (const auto& g : grids)
        if (g->getName() == name) return g;
    return nullptr;
}
}  // namespace

TEST_CASE("output: a NanoVDB file holds the .vdb's grids, classes and values, as NanoVDB's own reader reads them", "[output]") {
    const Band& band = test::sphereBand();
    std::vector<float> green(band.size());
    for (std::size_t i = 0; i < band.size(); ++i) green[i] = 0.5f * float(i);
    const std::vector<NamedChannel> extra{{"green", &green, 0.0f}};
    const std::filesystem::path dir = test::scratchDir() / "nanovdb";
    std::filesystem::create_directories(dir);
    for (const bool half : {false, true}) {
        INFO("half floats: " << half);
        VdbWriteOptions options;
        options.halfFloat = half;
        const std::string vdbPath = (dir / "band.vdb").string(), nvdbPath = (dir / "band.nvdb").string();
        writeBandVdb(band, vdbPath, openvdb::MetaMap(), extra, {}, options);
        options.nanoVdb = true;
        writeBandVdb(band, nvdbPath, openvdb::MetaMap(), extra, {}, options);
        CHECK(isNanoVdbPath(nvdbPath));
        CHECK_FALSE(isNanoVdbPath(vdbPath));

        openvdb::io::File file(vdbPath);
        file.open();
        const auto grids = file.getGrids();
        file.close();
        const auto handles = nanovdb::io::readGrids(nvdbPath);
        REQUIRE(handles.size() == grids->size());
        for (std::size_t k = 0; k < handles.size(); ++k) {
            const nanovdb::GridMetaData* meta = handles[k].gridMetaData();
            REQUIRE(meta);
            const std::string name = meta->shortGridName();
            INFO(name);
            const openvdb::GridBase::Ptr g = findGrid(*grids, name);
            REQUIRE(g);
            CHECK(meta->voxelSize()[0] == Approx(band.voxelSize));
            CHECK(meta->activeVoxelCount() == g->activeVoxelCount());
            const bool fog = g->getGridClass() == openvdb::GRID_FOG_VOLUME;
            CHECK((meta->gridClass() == nanovdb::GridClass::FogVolume) == fog);
            // Values as written: float32, or a half rounded (about 3 digits) in both files.
            const double tolerance = half ? 1e-3 : 0.0;
            if (auto f = openvdb::GridBase::grid<openvdb::FloatGrid>(g)) {
                std::size_t compared = 0;
                auto check = [&](auto* nano) {
                    REQUIRE(nano);
                    auto acc = nano->getAccessor();
                    for (auto it = f->cbeginValueOn(); it; ++it) {
                        const openvdb::Coord c = it.getCoord();
                        const double a = *it, b = acc.getValue(nanovdb::Coord(c.x(), c.y(), c.z()));
                        if (std::abs(a - b) > tolerance * std::max(1.0, std::abs(a))) FAIL("voxel " << c << ": " << a << " against " << b);
                        ++compared;
                        if (compared > 200000) break;  // the occupancy's interior: enough of it
                    }
                };
                if (half) check(handles[k].grid<nanovdb::Fp16>());
                else check(handles[k].grid<float>());
                CHECK(compared > 0);
            } else if (auto v = openvdb::GridBase::grid<openvdb::Vec3SGrid>(g)) {
                const auto* nano = handles[k].grid<nanovdb::Vec3f>();
                REQUIRE(nano);
                auto acc = nano->getAccessor();
                for (auto it = v->cbeginValueOn(); it; ++it) {
                    const openvdb::Coord c = it.getCoord();
                    const nanovdb::Vec3f b = acc.getValue(nanovdb::Coord(c.x(), c.y(), c.z()));
                    for (int d = 0; d < 3; ++d)
                        if (std::abs((*it)[d] - b[d]) > tolerance * std::max(1.0f, std::abs((*it)[d])))
                            FAIL("voxel " << c << " component " << d << ": " << (*it)[d] << " against " << b[d]);
                }
            } else {
                FAIL("a grid of type " << g->type());
            }
        }
    }
}

TEST_CASE("output: the occupancy's name may not be another grid's, and an empty name leaves it out", "[output]") {
    const Band& band = test::sphereBand();
    std::vector<float> values(band.size(), 1.0f);
    const std::string path = (test::scratchDir() / "named.vdb").string();
    VdbWriteOptions options;
    for (const std::string taken : {"mu", "stencil_width", "green"}) {
        INFO(taken);
        options.occupancyName = taken;
        CHECK_THROWS_AS(writeBandVdb(band, path, openvdb::MetaMap(), {{"green", &values}}, {}, options), ParameterError);
        CHECK_FALSE(std::filesystem::exists(path));
    }
    options.occupancyName = "";
    const openvdb::GridPtrVec grids = bandGrids(band, {}, {}, options);
    CHECK(grids.size() == 7);
    options.occupancyName = "occupancy";
    const openvdb::GridPtrVec named = bandGrids(band, {}, {}, options);
    REQUIRE(named.size() == 8);
    CHECK(named.back()->getName() == "occupancy");
}
