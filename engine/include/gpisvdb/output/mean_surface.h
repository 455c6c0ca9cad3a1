#pragma once
// The mean surface {γ = u} of a band file, with any grid sampled at its vertices (docs/operators.md, "Mesh export").
#include <array>
#include <openvdb/openvdb.h>
#include <string>
#include <utility>
#include <vector>

namespace gpisvdb {

struct SurfaceMesh {
    std::vector<openvdb::Vec3s> vertices;  ///< world units
    std::vector<std::array<int, 3>> triangles;
    std::vector<std::string> arrayNames;           ///< per-vertex arrays
    std::vector<std::vector<float>> arrays;        ///< arrays[k] has components(k) × vertices values
    std::vector<int> components;                   ///< 1 (float grid) or 3 (vec3 grid)
    std::string comment = "gpisvdb mean surface";  ///< the PLY header's comment line, a VTP's field data `comment`
};

/// Iso-surface of `mean` at u by OpenVDB's volumeToMesh. The band holds γ only near the surface: the values
/// outside it are filled with the side they lie on (signed flood fill of u − γ), so no spurious surface
/// appears where the band ends.
SurfaceMesh meanSurface(const openvdb::FloatGrid& mean, double iso);

/// Iso-surface {f = level} of a grid whose active voxels cover the region of interest (a dense field such as the
/// smoothed distance), by OpenVDB's volumeToMesh. Vertices in world units.
SurfaceMesh isoSurface(const openvdb::FloatGrid& grid, double level);

/// What meanSurface(mean, iso) and the mesh it returns allocate at their peak, bytes by part, counted before any of
/// it is allocated (docs/memory.md#mesh). The mesh's size comes from the crossing edges of the band (pairs of active
/// neighbours on either side of u): volumeToMesh makes one quad per crossing edge and, on a closed quad mesh, about
/// as many vertices as quads. The peak is the larger of the extraction's (u − γ over the mean's tree, the mesher's
/// sign and index leaves, its quad pools and point list, the points and quads it returns) and the finished mesh's
/// (vertices, triangles, `components` floats per vertex sampled on it, and with `polyData` VTK's copy for a .vtp
/// file or a render). `vertices`, when given, receives the mesh's vertex count so estimated.
std::vector<std::pair<std::string, double>> meanSurfaceBytes(const openvdb::FloatGrid& mean, double iso, int components, bool polyData,
                                                             double* vertices = nullptr);

/// What a finished mesh of `vertices` and `triangles` holds, bytes by part: its vertices (Vec3s) and triangles
/// (3 int), `components` floats per vertex sampled on it, and with `polyData` VTK's copy of them all (a .vtp file
/// or a render: float points, 64-bit offsets and connectivity, 32 B per triangle or 16 B per vertex cell of a mesh
/// without triangles, the float arrays).
std::vector<std::pair<std::string, double>> surfaceMeshBytes(double vertices, double triangles, int components, bool polyData);

/// Σ of the triangles' areas, world units².
double surfaceArea(const SurfaceMesh& mesh);

/// The Dirichlet energy Σ_t A_t |∇f_t|² of the piecewise-linear interpolant of vertex values f (the cotan
/// Laplacian's energy fᵀ L_cotan f), world units⁰ × f².
double dirichletEnergy(const SurfaceMesh& mesh, const std::vector<double>& f);

/// Adds `grid` (a float or vec3 grid) trilinearly sampled at the mesh's vertices, as an array named after it.
void sampleAtVertices(SurfaceMesh& mesh, const openvdb::GridBase& grid);

enum class MeshFormat { Ply, Vtp };
/// The format named by a path's extension (.ply or .vtp); throws OutputError otherwise.
MeshFormat meshFormatOf(const std::string& path);

/// Writes PLY (binary little endian; arrays as vertex properties) or VTP (VTK XML; arrays as point data; a mesh
/// without triangles as vertex cells).
/// Throws OutputError.
void writeMesh(const SurfaceMesh& mesh, const std::string& path, MeshFormat format);

}  // namespace gpisvdb
