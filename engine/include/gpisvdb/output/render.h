#pragma once
// Pictures of results (PNG): a grid's values on the mean surface, with a colour bar, shortest paths and an
// optional head-on slice, rendered offscreen by VTK. Several panels make one picture (the demo's σ comparison).
// VTK on Debian draws through X: without a usable DISPLAY the renderer starts its own Xvfb for the process.
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/core/types.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/slice_contour.h"

namespace gpisvdb {

/// Gray runs from black to white; Greys from white to mid grey (a light ground for lines drawn over it).
enum class Colormap { Viridis, Magma, Coolwarm, Gray, Greys };
/// "viridis", "magma", "coolwarm", "gray", "greys"; throws ParameterError otherwise.
Colormap colormapOf(const std::string& name);

/// "z=0.1", "x=-2": throws ParameterError otherwise.
SliceSpec sliceOf(const std::string& text);

/// Lines of one colour over a slice panel, e.g. sliceContour's level lines.
struct PanelLines {
    std::vector<std::vector<Vec3d>> polylines;  ///< world units; the coordinate along the slice's axis is ignored
    std::array<double, 3> colour{0, 0, 0};      ///< RGB in [0, 1]
    double width = 1.5;                         ///< pixels
};

struct RenderPanel {
    std::string title;                              ///< drawn above the panel
    const SurfaceMesh* surface = nullptr;           ///< drawn when set (world units)
    std::string array;                              ///< surface array to colour by (1 component); empty: plain grey
    std::vector<std::vector<Vec3d>> paths;          ///< polylines drawn over the surface, world units
    const openvdb::FloatGrid* sliceGrid = nullptr;  ///< with `slice`: drawn head-on, inactive voxels transparent
    SliceSpec slice;
    std::vector<PanelLines> sliceLines;  ///< drawn over the slice, in order (slice panels only)
    Colormap colormap = Colormap::Viridis;
    bool logScale = false;   ///< colours by log10 (needs positive values; others clamp to the lowest)
    bool symmetric = false;  ///< range ±max|value| (signed fields such as eigenfunctions)
    std::array<double, 2> range{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
};

struct RenderOptions {
    int panelWidth = 640, panelHeight = 520;  ///< pixels per panel
    int columns = 0;                          ///< panels per row; 0: all in one row
    double azimuth = -35;                     ///< camera direction about +z, degrees (0: looking from +x)
    double elevation = 35;                    ///< camera height above the xy plane, degrees
    std::string caption;                      ///< one line along the bottom of the picture
};

/// Renders the panels into one PNG (written to `path`). Throws ParameterError on an empty panel list, a panel
/// with nothing to draw or an unknown array, and OutputError when no X display can be had or the file cannot be
/// written.
/// Interrupted (Cancelled) between panels and before drawing and writing; VTK's own steps do not poll.
void renderPng(const std::vector<RenderPanel>& panels, const RenderOptions& options, const std::string& path,
               const Progress& progress = {});

}  // namespace gpisvdb
