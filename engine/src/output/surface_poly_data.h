#pragma once
// A SurfaceMesh as VTK PolyData: what the .vtp writer saves and the renderer draws.
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include "gpisvdb/output/mean_surface.h"

namespace gpisvdb {

/// Points, triangles (a mesh without triangles: one vertex cell per point, so viewers draw them) and every array
/// as float point data under its name.
vtkSmartPointer<vtkPolyData> surfacePolyData(const SurfaceMesh& mesh);

}  // namespace gpisvdb
