#include "gpisvdb/output/mean_surface.h"

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <vtkCellArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkXMLPolyDataWriter.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include "gpisvdb/core/errors.h"
#include "surface_poly_data.h"

namespace gpisvdb {

SurfaceMesh meanSurface(const openvdb::FloatGrid& mean, double iso) {
    // === u − γ: negative inside (γ ≈ 1), a level-set sign convention, then fill the outside of the band by side
    auto phi = openvdb::FloatGrid::create(1.0f);
    phi->setTransform(mean.transform().copy());
    phi->tree().topologyUnion(mean.tree());
    auto acc = phi->getAccessor();
    for (auto it = mean.cbeginValueOn(); it; ++it) acc.setValue(it.getCoord(), float(iso) - *it);
    openvdb::tools::signedFloodFill(phi->tree());
    return isoSurface(*phi, 0.0);
}

SurfaceMesh isoSurface(const openvdb::FloatGrid& grid, double level) {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(grid, points, tris, quads, level, 0.0);
    SurfaceMesh m;
    m.vertices = std::move(points);
    m.triangles.reserve(tris.size() + 2 * quads.size());  // at once: growth by doubling would hold up to 3× at its peak
    for (const auto& t : tris) m.triangles.push_back({int(t[0]), int(t[1]), int(t[2])});
    for (const auto& q : quads) {
        m.triangles.push_back({int(q[0]), int(q[1]), int(q[2])});
        m.triangles.push_back({int(q[0]), int(q[2]), int(q[3])});
    }
    return m;
}

std::vector<std::pair<std::string, double>> meanSurfaceBytes(const openvdb::FloatGrid& mean, double iso, int components, bool polyData,
                                                             double* vertexCount) {
    // === The crossing edges (one quad each) and the leaves that hold them, with the internal nodes above those
    //     leaves: the mesher's own trees (intersection, sign flags, point indices) allocate each such node
    using Tree = openvdb::FloatTree;
    using Lower = Tree::RootNodeType::ChildNodeType::ChildNodeType;  // 16³ children, 128 voxels wide
    using Upper = Tree::RootNodeType::ChildNodeType;                 // 32³ children, 4096 voxels wide
    double quads = 0, leaves = 0;
    std::set<openvdb::Coord> lowers, uppers;
    auto acc = mean.getConstAccessor();
    for (auto leaf = mean.tree().cbeginLeaf(); leaf; ++leaf) {
        bool crossed = false;
        for (auto v = leaf->cbeginValueOn(); v; ++v) {
            const bool inside = *v > iso;
            for (int axis = 0; axis < 3; ++axis) {
                openvdb::Coord n = v.getCoord();
                n[axis] += 1;
                float g = 0;
                if (acc.probeValue(n, g) && (g > iso) != inside) quads += 1, crossed = true;
            }
        }
        if (!crossed) continue;
        leaves += 1;
        lowers.insert(leaf->origin() & ~int(Lower::DIM - 1));
        uppers.insert(leaf->origin() & ~int(Upper::DIM - 1));
    }
    const double vertices = quads;  // a closed quad mesh has as many vertices as faces (Euler: V − E + F = 2, E = 2F)
    if (vertexCount) *vertexCount = vertices;
    using Int16Leaf = Tree::ValueConverter<openvdb::Int16>::Type::LeafNodeType;
    using IndexLeaf = Tree::ValueConverter<openvdb::Index32>::Type::LeafNodeType;
    using BoolLeaf = openvdb::BoolTree::LeafNodeType;
    // Internal nodes hold a pointer or a value per child whatever the value type: in each tree they cost what the
    // float tree's do
    const double nodes = double(lowers.size()) * double(sizeof(Lower)) + double(uppers.size()) * double(sizeof(Upper));
    // Extraction: u − γ on the mean's topology, then inside volumeToMesh its intersection (bool), sign (int16) and
    // point-index (uint32) trees, the first freed before its point list (Vec3s) and quad pools (Vec4I and a flag
    // byte per quad) are made; or, at the end of isoSurface, the points and quads it returned beside our triangles
    // (two 3 × int32 per quad).
    const double levelSet = double(mean.tree().memUsage());
    // (a leaf's values are a separate block of SIZE values beside the node, a bool leaf's a bit mask within it)
    const double signAndIndex = 2 * nodes + leaves * double(sizeof(Int16Leaf) + Int16Leaf::SIZE * sizeof(openvdb::Int16) +
                                                            sizeof(IndexLeaf) + IndexLeaf::SIZE * sizeof(openvdb::Index32));
    const double inMesher = signAndIndex + std::max(nodes + leaves * double(sizeof(BoolLeaf)), 12.0 * vertices + 17.0 * quads);
    const double returned = 12.0 * vertices + 16.0 * quads + 24.0 * quads;
    const double extraction = levelSet + std::max(inMesher, returned);
    // The finished mesh: two triangles per quad
    std::vector<std::pair<std::string, double>> finished = surfaceMeshBytes(vertices, 2 * quads, components, polyData);
    double mesh = 0;
    for (const auto& p : finished) mesh += p.second;
    if (extraction >= mesh)
        return {{"level_set", levelSet}, {inMesher > returned ? "mesher_trees_and_pools" : "mesher_output", extraction - levelSet}};
    return finished;
}

std::vector<std::pair<std::string, double>> surfaceMeshBytes(double vertices, double triangles, int components, bool polyData) {
    const double mesh = 12.0 * vertices + 12.0 * triangles, arrays = 4.0 * components * vertices;
    std::vector<std::pair<std::string, double>> parts = {{"mesh", mesh}, {"sampled_arrays", arrays}};
    if (polyData) {
        const double cells = triangles > 0 ? 32.0 * triangles : 16.0 * vertices;
        parts.emplace_back("vtk_poly_data", 12.0 * vertices + cells + arrays);
    }
    return parts;
}

double surfaceArea(const SurfaceMesh& mesh) {
    double a = 0;
    for (const auto& t : mesh.triangles) {
        const openvdb::Vec3d p0(mesh.vertices[std::size_t(t[0])]), p1(mesh.vertices[std::size_t(t[1])]),
            p2(mesh.vertices[std::size_t(t[2])]);
        a += 0.5 * (p1 - p0).cross(p2 - p0).length();
    }
    return a;
}

double dirichletEnergy(const SurfaceMesh& mesh, const std::vector<double>& f) {
    if (f.size() != mesh.vertices.size()) throw Error("dirichletEnergy: one value per vertex is needed");
    double e = 0;
    for (const auto& t : mesh.triangles) {
        const openvdb::Vec3d p0(mesh.vertices[std::size_t(t[0])]), p1(mesh.vertices[std::size_t(t[1])]),
            p2(mesh.vertices[std::size_t(t[2])]);
        const openvdb::Vec3d n = (p1 - p0).cross(p2 - p0);
        const double twiceArea = n.length();
        if (!(twiceArea > 0)) continue;
        // ∇f = n̂ × g / 2A with g = Σ_i f_i e_i, e_i the edge opposite vertex i (in the plane, so |n̂ × g| = |g|):
        // A |∇f|² = |g|² / (2 · 2A).
        const openvdb::Vec3d g = f[std::size_t(t[0])] * (p2 - p1) + f[std::size_t(t[1])] * (p0 - p2) + f[std::size_t(t[2])] * (p1 - p0);
        e += g.lengthSqr() / (2.0 * twiceArea);
    }
    return e;
}

void sampleAtVertices(SurfaceMesh& mesh, const openvdb::GridBase& grid) {
    std::vector<float> values;
    int comps = 0;
    if (const auto* f = dynamic_cast<const openvdb::FloatGrid*>(&grid)) {
        openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> s(*f);
        values.reserve(mesh.vertices.size());  // exactly: what meanSurfaceBytes counts, not up to twice that
        for (const auto& p : mesh.vertices) values.push_back(s.wsSample(openvdb::Vec3d(p)));
        comps = 1;
    } else if (const auto* v = dynamic_cast<const openvdb::Vec3SGrid*>(&grid)) {
        openvdb::tools::GridSampler<openvdb::Vec3SGrid, openvdb::tools::BoxSampler> s(*v);
        values.reserve(3 * mesh.vertices.size());
        for (const auto& p : mesh.vertices) {
            const openvdb::Vec3s x = s.wsSample(openvdb::Vec3d(p));
            values.insert(values.end(), {x[0], x[1], x[2]});
        }
        comps = 3;
    } else {
        throw InputError("grid '" + grid.getName() + "' is neither a float nor a vec3 grid");
    }
    mesh.arrayNames.push_back(grid.getName());
    mesh.arrays.push_back(std::move(values));
    mesh.components.push_back(comps);
}

MeshFormat meshFormatOf(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".ply") return MeshFormat::Ply;
    if (ext == ".vtp") return MeshFormat::Vtp;
    throw OutputError(path + ": unknown mesh extension '" + ext + "' (use .ply or .vtp)");
}

void writeMesh(const SurfaceMesh& mesh, const std::string& path, MeshFormat format) {
    if (format == MeshFormat::Ply) {
        std::ofstream out(path, std::ios::binary);
        std::string comment = mesh.comment;
        std::replace(comment.begin(), comment.end(), '\n', ' ');  // one header line
        out << "ply\nformat binary_little_endian 1.0\ncomment " << comment << "\nelement vertex " << mesh.vertices.size()
            << "\nproperty float x\nproperty float y\nproperty float z\n";
        for (std::size_t k = 0; k < mesh.arrays.size(); ++k) {
            if (mesh.components[k] == 1) out << "property float " << mesh.arrayNames[k] << "\n";
            else
                for (const char* c : {"_x", "_y", "_z"}) out << "property float " << mesh.arrayNames[k] << c << "\n";
        }
        out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
        for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
            out.write(reinterpret_cast<const char*>(mesh.vertices[i].asPointer()), 3 * sizeof(float));
            for (std::size_t k = 0; k < mesh.arrays.size(); ++k)
                out.write(reinterpret_cast<const char*>(&mesh.arrays[k][i * std::size_t(mesh.components[k])]),
                          std::streamsize(sizeof(float) * std::size_t(mesh.components[k])));
        }
        const unsigned char three = 3;
        for (const auto& t : mesh.triangles) {
            out.write(reinterpret_cast<const char*>(&three), 1);
            out.write(reinterpret_cast<const char*>(t.data()), 3 * sizeof(int));
        }
        out.close();  // the last buffer's flush can fail too (a full disk)
        if (!out) throw OutputError(path + ": writing the mesh failed");
        return;
    }
    // === VTP
    const auto pd = surfacePolyData(mesh);
    auto comment = vtkSmartPointer<vtkStringArray>::New();  // field data: what the PLY header's comment says
    comment->SetName("comment");
    comment->InsertNextValue(mesh.comment);
    pd->GetFieldData()->AddArray(comment);
    auto w = vtkSmartPointer<vtkXMLPolyDataWriter>::New();
    w->SetFileName(path.c_str());
    w->SetInputData(pd);
    if (w->Write() != 1) throw OutputError(path + ": writing the mesh failed");
}

vtkSmartPointer<vtkPolyData> surfacePolyData(const SurfaceMesh& mesh) {
    auto pd = vtkSmartPointer<vtkPolyData>::New();
    auto pts = vtkSmartPointer<vtkPoints>::New();
    for (const auto& p : mesh.vertices) pts->InsertNextPoint(p[0], p[1], p[2]);
    auto cells = vtkSmartPointer<vtkCellArray>::New();
    for (const auto& t : mesh.triangles) {
        const vtkIdType ids[3] = {t[0], t[1], t[2]};
        cells->InsertNextCell(3, ids);
    }
    pd->SetPoints(pts);
    pd->SetPolys(cells);
    if (mesh.triangles.empty()) {
        auto verts = vtkSmartPointer<vtkCellArray>::New();
        for (vtkIdType i = 0; i < vtkIdType(mesh.vertices.size()); ++i) verts->InsertNextCell(1, &i);
        pd->SetVerts(verts);
    }
    for (std::size_t k = 0; k < mesh.arrays.size(); ++k) {
        auto a = vtkSmartPointer<vtkFloatArray>::New();
        a->SetName(mesh.arrayNames[k].c_str());
        a->SetNumberOfComponents(mesh.components[k]);
        for (float v : mesh.arrays[k]) a->InsertNextValue(v);
        pd->GetPointData()->AddArray(a);
    }
    return pd;
}

}  // namespace gpisvdb
