#include <catch2/catch.hpp>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/output/mean_surface.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

openvdb::FloatGrid::Ptr floatGrid(const Band& band, const std::vector<float>& values, const char* name) {
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName(name);
    g->setTransform(band.index->transform().copy());
    auto acc = g->getAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) acc.setValue(band.coord[i], values[i]);
    return g;
}

}  // namespace

TEST_CASE("mesh: the mean surface of a sphere band is one closed sphere of the right radius", "[mesh]") {
    openvdb::initialize();
    const SoupSamples ss = soupSamples(icosphere(3), {1.0});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    BandOptions o;
    o.voxelSize = 0.05;
    const Band band = buildBand(model, ss.samples, o).band;
    SurfaceMesh mesh = meanSurface(*floatGrid(band, band.mean, "mean"), 0.5);
    REQUIRE(!mesh.triangles.empty());
    // Euler characteristic V − E + F = 2 for one closed genus-0 surface (E = 3F/2): no shell at the band's edges.
    CHECK(long(mesh.vertices.size()) - long(mesh.triangles.size()) / 2 == 2);
    for (const auto& v : mesh.vertices) CHECK(std::abs(v.length() - 1.0) < 0.05);
    sampleAtVertices(mesh, *floatGrid(band, band.mu, "mu"));
    REQUIRE(mesh.arrays.size() == 1);
    for (float m : mesh.arrays[0]) CHECK(m > 0);

    // PLY, read back by our reader; VTP, by VTK's.
    const std::string ply = (test::scratchDir() / "sphere.ply").string(), vtp = (test::scratchDir() / "sphere.vtp").string();
    writeMesh(mesh, ply, meshFormatOf(ply));
    writeMesh(mesh, vtp, meshFormatOf(vtp));
    const InputData back = readInput(ply);
    REQUIRE(back.soup);
    CHECK(back.soup->vertices.size() == mesh.vertices.size());
    CHECK(back.soup->triangles.size() == mesh.triangles.size());
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(vtp.c_str());
    reader->Update();
    CHECK(reader->GetOutput()->GetNumberOfPoints() == vtkIdType(mesh.vertices.size()));
    REQUIRE(reader->GetOutput()->GetPointData()->GetArray("mu") != nullptr);
    CHECK(reader->GetOutput()->GetPointData()->GetArray("mu")->GetNumberOfTuples() == vtkIdType(mesh.vertices.size()));
    CHECK_THROWS_AS(meshFormatOf("x.obj"), OutputError);
}
