#include "gpisvdb/output/paths.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

PathFormat pathFormatOf(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".vtp") return PathFormat::Vtp;
    if (ext == ".obj") return PathFormat::Obj;
    if (ext == ".json") return PathFormat::Json;
    throw OutputError(path + ": unknown path extension '" + ext + "' (use .vtp, .obj or .json)");
}

std::vector<std::vector<Vec3d>> readPolylines(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path + ": no such file");
    if (pathFormatOf(path) != PathFormat::Vtp) throw InputError(path + ": paths are read from .vtp files only");
    vtkObject::GlobalWarningDisplayOff();  // a bad file is reported once, below
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkPolyData* pd = reader->GetOutput();
    if (reader->GetErrorCode() != 0 || !pd || !pd->GetPoints() || pd->GetNumberOfLines() == 0)
        throw InputError(path + ": not a VTK PolyData file with lines");
    std::vector<std::vector<Vec3d>> lines;
    vtkCellArray* cells = pd->GetLines();
    auto ids = vtkSmartPointer<vtkIdList>::New();
    for (cells->InitTraversal(); cells->GetNextCell(ids);) {
        std::vector<Vec3d> line;
        for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k) {
            double x[3];
            pd->GetPoint(ids->GetId(k), x);
            line.emplace_back(x[0], x[1], x[2]);
        }
        lines.push_back(std::move(line));
    }
    return lines;
}

void writePaths(const std::vector<GeodesicPath>& paths, const std::string& path, PathFormat format) {
    if (format == PathFormat::Json) {
        nlohmann::json j = {{"units", "world"}, {"paths", nlohmann::json::array()}};
        for (const GeodesicPath& p : paths) {
            nlohmann::json points = nlohmann::json::array(), values = nlohmann::json::array();
            for (const Vec3d& x : p.points) points.push_back({x.x(), x.y(), x.z()});
            for (double u : p.values) values.push_back(std::isfinite(u) ? nlohmann::json(u) : nlohmann::json());
            j["paths"].push_back({{"points", points},
                                  {"geodesic", values},
                                  {"length", p.length},
                                  {"distance", std::isfinite(p.distance) ? nlohmann::json(p.distance) : nlohmann::json()},
                                  {"reached_source", p.reachedSource}});
        }
        std::ofstream out(path);
        out << j.dump(1) << "\n";
        if (!out) throw OutputError(path + ": writing the paths failed");
        return;
    }
    if (format == PathFormat::Obj) {
        std::ofstream out(path);
        out << "# gpisvdb shortest paths, world units, one 'l' polyline per target\n" << std::setprecision(9);
        for (const GeodesicPath& p : paths)
            for (const Vec3d& x : p.points) out << "v " << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
        std::size_t first = 1;
        for (const GeodesicPath& p : paths) {
            out << 'l';
            for (std::size_t i = 0; i < p.points.size(); ++i) out << ' ' << first + i;
            out << '\n';
            first += p.points.size();
        }
        if (!out) throw OutputError(path + ": writing the paths failed");
        return;
    }
    // === VTP
    auto pd = vtkSmartPointer<vtkPolyData>::New();
    auto pts = vtkSmartPointer<vtkPoints>::New();
    pts->SetDataTypeToDouble();
    auto lines = vtkSmartPointer<vtkCellArray>::New();
    auto u = vtkSmartPointer<vtkDoubleArray>::New();
    u->SetName("geodesic");
    auto length = vtkSmartPointer<vtkDoubleArray>::New();
    length->SetName("length");
    for (const GeodesicPath& p : paths) {
        std::vector<vtkIdType> ids;
        for (std::size_t i = 0; i < p.points.size(); ++i) {
            ids.push_back(pts->InsertNextPoint(p.points[i].x(), p.points[i].y(), p.points[i].z()));
            u->InsertNextValue(std::isfinite(p.values[i]) ? p.values[i] : std::nan(""));
        }
        lines->InsertNextCell(vtkIdType(ids.size()), ids.data());
        length->InsertNextValue(p.length);
    }
    pd->SetPoints(pts);
    pd->SetLines(lines);
    pd->GetPointData()->AddArray(u);
    pd->GetCellData()->AddArray(length);
    auto w = vtkSmartPointer<vtkXMLPolyDataWriter>::New();
    w->SetFileName(path.c_str());
    w->SetInputData(pd);
    if (w->Write() != 1) throw OutputError(path + ": writing the paths failed");
}

}  // namespace gpisvdb
