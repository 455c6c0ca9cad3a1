#include "gpisvdb/output/render.h"

#include <openvdb/tools/Interpolation.h>
#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkColorTransferFunction.h>
#include <vtkDataSetMapper.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkLookupTable.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>
#include <vtkRenderWindow.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTubeFilter.h>
#include <vtkWindowToImageFilter.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "gpisvdb/core/errors.h"
#include "headless_display.h"
#include "surface_poly_data.h"

namespace gpisvdb {

template <class T>
using Ptr = vtkSmartPointer<T>;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kCaptionHeight = 26;

// Control points (position, r, g, b) of matplotlib's perceptually uniform maps, sampled at ninths.
const std::vector<std::array<double, 4>> kViridis = {
    {0.000, 0.267, 0.005, 0.329}, {0.125, 0.283, 0.141, 0.458}, {0.250, 0.254, 0.265, 0.530},
    {0.375, 0.207, 0.372, 0.553}, {0.500, 0.164, 0.471, 0.558}, {0.625, 0.128, 0.567, 0.551},
    {0.750, 0.135, 0.659, 0.518}, {0.875, 0.360, 0.786, 0.408}, {1.000, 0.993, 0.906, 0.144}};
const std::vector<std::array<double, 4>> kMagma = {
    {0.000, 0.001, 0.000, 0.014}, {0.125, 0.114, 0.066, 0.270}, {0.250, 0.316, 0.071, 0.485},
    {0.375, 0.497, 0.138, 0.507}, {0.500, 0.716, 0.215, 0.475}, {0.625, 0.904, 0.310, 0.400},
    {0.750, 0.987, 0.536, 0.382}, {0.875, 0.996, 0.766, 0.534}, {1.000, 0.987, 0.991, 0.750}};

Ptr<vtkLookupTable> lookupTable(Colormap map, std::array<double, 2> range, bool logScale) {
    auto ctf = Ptr<vtkColorTransferFunction>::New();
    switch (map) {
        case Colormap::Viridis:
            for (const auto& p : kViridis) ctf->AddRGBPoint(p[0], p[1], p[2], p[3]);
            break;
        case Colormap::Magma:
            for (const auto& p : kMagma) ctf->AddRGBPoint(p[0], p[1], p[2], p[3]);
            break;
        case Colormap::Coolwarm:  // Moreland's diverging map
            ctf->SetColorSpaceToDiverging();
            ctf->AddRGBPoint(0.0, 0.230, 0.299, 0.754);
            ctf->AddRGBPoint(1.0, 0.706, 0.016, 0.150);
            break;
        case Colormap::Gray:
            ctf->AddRGBPoint(0.0, 0.05, 0.05, 0.05);
            ctf->AddRGBPoint(1.0, 0.95, 0.95, 0.95);
            break;
        case Colormap::Greys:
            ctf->AddRGBPoint(0.0, 0.98, 0.98, 0.98);
            ctf->AddRGBPoint(1.0, 0.55, 0.55, 0.55);
            break;
    }
    auto lut = Ptr<vtkLookupTable>::New();
    lut->SetNumberOfTableValues(256);
    for (int i = 0; i < 256; ++i) {
        double rgb[3];
        ctf->GetColor(i / 255.0, rgb);
        lut->SetTableValue(i, rgb[0], rgb[1], rgb[2], 1.0);
    }
    if (logScale) lut->SetScaleToLog10();
    lut->SetRange(range[0], range[1]);
    lut->SetNanColor(0.85, 0.85, 0.85, 0.0);
    lut->Build();
    return lut;
}

/// Colour range of finite values (positive ones for a log scale), honouring a fixed range and symmetry.
std::array<double, 2> colourRange(const std::vector<float>& values, const RenderPanel& panel) {
    std::array<double, 2> r = panel.range;
    if (std::isfinite(r[0]) && std::isfinite(r[1])) return r;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, absMax = 0;
    for (float v : values) {
        if (!std::isfinite(v) || (panel.logScale && v <= 0)) continue;
        lo = std::min(lo, double(v)), hi = std::max(hi, double(v)), absMax = std::max(absMax, std::abs(double(v)));
    }
    if (!(lo <= hi)) {
        if (panel.logScale)
            throw ParameterError(
                "a log colour scale (RenderPanel::logScale) needs positive values, and '" + panel.array + "' has none here",
                {"RenderPanel::logScale"});
        lo = 0, hi = 1;
    }
    if (panel.symmetric) lo = -absMax, hi = absMax;
    if (hi <= lo) hi = lo + (lo == 0 ? 1.0 : std::abs(lo) * 1e-3);
    if (!std::isfinite(r[0])) r[0] = lo;
    if (!std::isfinite(r[1])) r[1] = hi;
    return r;
}

Ptr<vtkTextActor> text(const std::string& s, int size, bool bold) {
    auto t = Ptr<vtkTextActor>::New();
    t->SetInput(s.c_str());
    vtkTextProperty* p = t->GetTextProperty();
    p->SetFontSize(size);
    p->SetBold(bold);
    p->SetColor(0.1, 0.1, 0.1);
    p->SetJustificationToCentered();
    p->SetVerticalJustificationToTop();
    t->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    return t;
}

Ptr<vtkScalarBarActor> colourBar(vtkLookupTable* lut, const std::string& title) {
    auto bar = Ptr<vtkScalarBarActor>::New();
    bar->SetLookupTable(lut);
    bar->SetTitle(title.c_str());
    bar->SetNumberOfLabels(5);
    bar->SetLabelFormat("%-#6.3g");
    bar->SetOrientationToHorizontal();
    bar->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    bar->SetPosition(0.15, 0.01);
    bar->SetWidth(0.7);
    bar->SetHeight(0.16);
    bar->SetBarRatio(0.25);
    bar->SetTextPositionToPrecedeScalarBar();  // labels under the bar, the title above it
    for (vtkTextProperty* p : {bar->GetTitleTextProperty(), bar->GetLabelTextProperty()}) {
        p->SetColor(0.1, 0.1, 0.1);
        p->SetShadow(false);
        p->SetItalic(false);
    }
    bar->GetLabelTextProperty()->SetBold(false);
    bar->UnconstrainedFontSizeOn();
    bar->GetTitleTextProperty()->SetFontSize(16);
    bar->GetLabelTextProperty()->SetFontSize(13);
    return bar;
}

const std::vector<float>& surfaceArray(const RenderPanel& panel) {
    const SurfaceMesh& m = *panel.surface;
    for (std::size_t k = 0; k < m.arrayNames.size(); ++k)
        if (m.arrayNames[k] == panel.array) {
            if (m.components[k] != 1) throw ParameterError("'" + panel.array + "' is a vector field: pictures colour scalar fields only");
            return m.arrays[k];
        }
    throw ParameterError("the surface has no array '" + panel.array + "'");
}

/// Camera along (azimuth, elevation) looking at the scene's centre, z up, fitted to the scene.
void placeCamera(vtkRenderer* r, const RenderOptions& o) {
    double b[6];
    r->ComputeVisiblePropBounds(b);
    const Vec3d c(0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.5 * (b[4] + b[5]));
    const double az = o.azimuth * kPi / 180, el = o.elevation * kPi / 180;
    const Vec3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    vtkCamera* cam = r->GetActiveCamera();
    cam->SetFocalPoint(c.x(), c.y(), c.z());
    cam->SetPosition(c.x() + dir.x(), c.y() + dir.y(), c.z() + dir.z());
    cam->SetViewUp(0, 0, 1);
    r->ResetCamera();
    cam->Zoom(1.25);
}

void addSurface(vtkRenderer* r, const RenderPanel& panel) {
    auto pd = surfacePolyData(*panel.surface);
    auto mapper = Ptr<vtkPolyDataMapper>::New();
    if (!panel.array.empty()) {
        const std::vector<float>& values = surfaceArray(panel);
        pd->GetPointData()->SetActiveScalars(panel.array.c_str());
        const auto range = colourRange(values, panel);
        auto lut = lookupTable(panel.colormap, range, panel.logScale);
        mapper->SetLookupTable(lut);
        mapper->SetScalarRange(range[0], range[1]);
        mapper->UseLookupTableScalarRangeOn();
        mapper->InterpolateScalarsBeforeMappingOn();
        r->AddActor2D(colourBar(lut, panel.array + (panel.logScale ? " (log)" : "")));
    } else {
        mapper->ScalarVisibilityOff();
    }
    auto normals = Ptr<vtkPolyDataNormals>::New();
    normals->SetInputData(pd);
    normals->SplittingOff();
    mapper->SetInputConnection(normals->GetOutputPort());
    auto actor = Ptr<vtkActor>::New();
    actor->SetMapper(mapper);
    actor->GetProperty()->SetColor(0.8, 0.8, 0.8);
    actor->GetProperty()->SetSpecular(0.15);
    r->AddActor(actor);

    // === Paths as tubes a little thicker than a line, so they stay visible where they dip below the surface
    if (panel.paths.empty()) return;
    double b[6];
    pd->GetBounds(b);
    const double diag = std::sqrt((b[1] - b[0]) * (b[1] - b[0]) + (b[3] - b[2]) * (b[3] - b[2]) + (b[5] - b[4]) * (b[5] - b[4]));
    auto lines = Ptr<vtkPolyData>::New();
    auto pts = Ptr<vtkPoints>::New();
    auto cells = Ptr<vtkCellArray>::New();
    for (const auto& path : panel.paths) {
        if (path.size() < 2) continue;
        cells->InsertNextCell(vtkIdType(path.size()));
        for (const Vec3d& p : path) cells->InsertCellPoint(pts->InsertNextPoint(p.x(), p.y(), p.z()));
    }
    lines->SetPoints(pts);
    lines->SetLines(cells);
    auto tube = Ptr<vtkTubeFilter>::New();
    tube->SetInputData(lines);
    tube->SetRadius(0.006 * (diag > 0 ? diag : 1));
    tube->SetNumberOfSides(10);
    auto tubeMapper = Ptr<vtkPolyDataMapper>::New();
    tubeMapper->SetInputConnection(tube->GetOutputPort());
    tubeMapper->ScalarVisibilityOff();
    auto tubeActor = Ptr<vtkActor>::New();
    tubeActor->SetMapper(tubeMapper);
    tubeActor->GetProperty()->SetColor(0.9, 0.1, 0.1);
    r->AddActor(tubeActor);
}

/// The grid on the plane axis = value, one sample per voxel over the active bounding box; inactive: NaN.
void addSlice(vtkRenderer* r, const RenderPanel& panel) {
    const openvdb::FloatGrid& grid = *panel.sliceGrid;
    const openvdb::CoordBBox bb = grid.evalActiveVoxelBoundingBox();
    if (bb.empty()) throw ParameterError("grid '" + grid.getName() + "' has no active voxels to slice");
    const int a = panel.slice.axis, u = (a + 1) % 3, v = (a + 2) % 3;
    const int iu = a == 1 ? v : u, iv = a == 1 ? u : v;  // keep a right-handed (u, v) view for y slices
    const openvdb::Vec3d sliceIndex = grid.transform().worldToIndex(openvdb::Vec3d(panel.slice.value));
    const double k = sliceIndex[a];
    if (k < bb.min()[a] - 0.5 || k > bb.max()[a] + 0.5)
        throw ParameterError("the slice " + std::string(1, "xyz"[a]) + "=" + numberText(panel.slice.value) + " misses the grid '" +
                             grid.getName() + "' (active voxels between " + numberText(grid.transform().indexToWorld(bb.min())[a]) +
                             " and " + numberText(grid.transform().indexToWorld(bb.max())[a]) + ")");
    const int nu = bb.dim()[iu], nv = bb.dim()[iv];
    const double h = grid.voxelSize()[0];
    auto image = Ptr<vtkImageData>::New();
    image->SetDimensions(nu, nv, 1);
    image->SetSpacing(h, h, h);
    image->SetOrigin(bb.min()[iu] * h, bb.min()[iv] * h, 0);
    auto values = Ptr<vtkFloatArray>::New();
    values->SetName(grid.getName().c_str());
    values->SetNumberOfValues(vtkIdType(nu) * nv);
    std::vector<float> finite;
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(grid);
    auto acc = grid.getConstAccessor();
    for (int j = 0; j < nv; ++j)
        for (int i = 0; i < nu; ++i) {
            openvdb::Vec3d x;
            x[a] = k, x[iu] = bb.min()[iu] + i, x[iv] = bb.min()[iv] + j;
            const bool active = acc.isValueOn(openvdb::Coord::round(x));
            const float value = active ? float(sampler.isSample(x)) : std::numeric_limits<float>::quiet_NaN();
            values->SetValue(vtkIdType(j) * nu + i, value);
            if (active) finite.push_back(value);
        }
    image->GetPointData()->SetScalars(values);
    const auto range = colourRange(finite, panel);
    auto lut = lookupTable(panel.colormap, range, panel.logScale);
    auto mapper = Ptr<vtkDataSetMapper>::New();
    mapper->SetInputData(image);
    mapper->SetLookupTable(lut);
    mapper->SetScalarRange(range[0], range[1]);
    mapper->UseLookupTableScalarRangeOn();
    auto actor = Ptr<vtkActor>::New();
    actor->SetMapper(mapper);
    actor->GetProperty()->LightingOff();
    r->AddActor(actor);
    r->AddActor2D(colourBar(lut, grid.getName() + (panel.logScale ? " (log)" : "")));

    // === Lines over the image: world points into the image's (u, v) frame, a little towards the camera
    for (const PanelLines& group : panel.sliceLines) {
        auto pts = Ptr<vtkPoints>::New();
        auto cells = Ptr<vtkCellArray>::New();
        for (const auto& line : group.polylines) {
            if (line.size() < 2) continue;
            cells->InsertNextCell(vtkIdType(line.size()));
            for (const Vec3d& p : line) {
                const openvdb::Vec3d x = grid.transform().worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z()));
                cells->InsertCellPoint(pts->InsertNextPoint(x[iu] * h, x[iv] * h, 0.01 * h));
            }
        }
        auto lines = Ptr<vtkPolyData>::New();
        lines->SetPoints(pts);
        lines->SetLines(cells);
        auto lineMapper = Ptr<vtkPolyDataMapper>::New();
        lineMapper->SetInputData(lines);
        lineMapper->ScalarVisibilityOff();
        auto lineActor = Ptr<vtkActor>::New();
        lineActor->SetMapper(lineMapper);
        lineActor->GetProperty()->SetColor(group.colour[0], group.colour[1], group.colour[2]);
        lineActor->GetProperty()->SetLineWidth(float(group.width));
        lineActor->GetProperty()->LightingOff();
        r->AddActor(lineActor);
    }
    vtkCamera* cam = r->GetActiveCamera();
    cam->ParallelProjectionOn();
    r->ResetCamera();
    cam->Zoom(1.2);
}

}  // namespace

Colormap colormapOf(const std::string& name) {
    if (name == "viridis") return Colormap::Viridis;
    if (name == "magma") return Colormap::Magma;
    if (name == "coolwarm") return Colormap::Coolwarm;
    if (name == "gray" || name == "grey") return Colormap::Gray;
    if (name == "greys") return Colormap::Greys;
    throw ParameterError("unknown colour map '" + name + "' (viridis, magma, coolwarm, gray or greys)");
}

SliceSpec sliceOf(const std::string& text) {
    SliceSpec s;
    const auto eq = text.find('=');
    const std::string axis = text.substr(0, eq);
    if (eq == std::string::npos || axis.size() != 1 || std::string("xyz").find(axis[0]) == std::string::npos)
        throw ParameterError("slice plane (RenderPanel::slice): expected axis=value with axis x, y or z (e.g. z=0.1), got '" + text + "'",
                             {"RenderPanel::slice"});
    s.axis = int(std::string("xyz").find(axis[0]));
    char* end = nullptr;
    const std::string number = text.substr(eq + 1);
    s.value = std::strtod(number.c_str(), &end);
    if (number.empty() || *end != '\0' || !std::isfinite(s.value))
        throw ParameterError("slice plane (RenderPanel::slice): '" + number + "' is not a finite number", {"RenderPanel::slice"});
    return s;
}

void renderPng(const std::vector<RenderPanel>& panels, const RenderOptions& o, const std::string& path, const Progress& progress) {
    if (panels.empty()) throw ParameterError("nothing to render");
    if (o.panelWidth < 64 || o.panelHeight < 64 || o.panelWidth > 8192 || o.panelHeight > 8192)
        throw ParameterError("picture panels must be 64 to 8192 pixels wide and high");
    for (const RenderPanel& p : panels) {
        if (bool(p.surface) == bool(p.sliceGrid)) throw ParameterError("a picture panel shows either a surface or a slice");
        if (p.surface && !p.sliceLines.empty()) throw ParameterError("lines over a slice need a slice panel");
    }
    // Refused before rendering: cheaper, and VTK's PNG writer leaks libpng's structures on its own error path.
    const std::filesystem::path folder = std::filesystem::path(path).has_parent_path() ? std::filesystem::path(path).parent_path() : ".";
    if (!std::filesystem::is_directory(folder) || access(folder.c_str(), W_OK) != 0)
        throw OutputError(path + ": cannot write the PNG (the folder " + folder.string() + " does not exist or is not writable)");
    const int columns = o.columns > 0 ? std::min<int>(o.columns, int(panels.size())) : int(panels.size());
    const int rows = (int(panels.size()) + columns - 1) / columns;
    const int caption = o.caption.empty() ? 0 : kCaptionHeight;
    const int width = columns * o.panelWidth, height = rows * o.panelHeight + caption;
    const double captionFrac = double(caption) / height;
    ensureDisplay();
    vtkObject::GlobalWarningDisplayOff();  // failures are reported once, as exceptions

    auto window = Ptr<vtkRenderWindow>::New();
    window->SetOffScreenRendering(1);
    window->SetSize(width, height);
    window->SetMultiSamples(8);
    for (std::size_t n = 0; n < panels.size(); ++n) {
        progress.checkInterrupt();
        const RenderPanel& panel = panels[n];
        const int col = int(n) % columns, row = int(n) / columns;
        auto r = Ptr<vtkRenderer>::New();
        r->SetBackground(1, 1, 1);
        r->SetViewport(double(col) / columns, captionFrac + (1 - captionFrac) * (rows - 1 - row) / rows, double(col + 1) / columns,
                       captionFrac + (1 - captionFrac) * (rows - row) / rows);
        if (panel.surface) {
            addSurface(r, panel);
            placeCamera(r, o);
        } else {
            addSlice(r, panel);
        }
        if (!panel.title.empty()) {
            auto t = text(panel.title, 18, true);
            t->SetPosition(0.5, 0.97);
            r->AddActor2D(t);
        }
        window->AddRenderer(r);
    }
    if (caption) {
        auto r = Ptr<vtkRenderer>::New();
        r->SetBackground(1, 1, 1);
        r->SetViewport(0, 0, 1, captionFrac);
        auto t = text(o.caption, 13, false);
        t->SetPosition(0.5, 0.85);
        r->AddActor2D(t);
        window->AddRenderer(r);
    }
    progress.checkInterrupt();
    window->Render();

    auto grab = Ptr<vtkWindowToImageFilter>::New();
    grab->SetInput(window);
    grab->SetInputBufferTypeToRGB();
    grab->ReadFrontBufferOff();
    grab->Update();
    progress.checkInterrupt();
    auto writer = Ptr<vtkPNGWriter>::New();
    writer->SetFileName(path.c_str());
    writer->SetInputConnection(grab->GetOutputPort());
    writer->Write();
    std::error_code ec;
    if (writer->GetErrorCode() != 0 || std::filesystem::file_size(path, ec) == 0 || ec) throw OutputError(path + ": cannot write the PNG");
}

}  // namespace gpisvdb
