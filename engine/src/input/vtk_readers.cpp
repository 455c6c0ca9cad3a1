// STL and VTP through VTK's readers; VTK reports errors through events, which we turn into InputError.
#include <vtkCellArray.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkSTLReader.h>
#include <vtkXMLPolyDataReader.h>

#include "readers.h"

namespace gpisvdb::detail {

namespace {

class ErrorCapture : public vtkCommand {
public:
    static ErrorCapture* New() { return new ErrorCapture; }
    void Execute(vtkObject*, unsigned long, void* data) override {
        if (message.empty() && data) message = static_cast<const char*>(data);
    }
    std::string message;
};

template <class Reader>
vtkPolyData* run(Reader* reader, const std::string& path, const char* format) {
    vtkNew<ErrorCapture> errors;
    reader->AddObserver(vtkCommand::ErrorEvent, errors);
    reader->AddObserver(vtkCommand::WarningEvent, errors);
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkPolyData* out = reader->GetOutput();
    if (!errors->message.empty() || !out || out->GetNumberOfPoints() == 0) {
        std::string why = errors->message;
        if (const auto nl = why.find_last_of('\n', why.size() > 1 ? why.size() - 2 : 0); nl != std::string::npos) why = why.substr(nl + 1);
        while (!why.empty() && (why.back() == '\n' || why.back() == ' ')) why.pop_back();
        fail(path, 0, std::string("could not be read as ") + format + (why.empty() ? " (no points)" : ": " + why));
    }
    return out;
}

std::vector<Vec3d> pointsOf(vtkPolyData* pd) {
    std::vector<Vec3d> pts(std::size_t(pd->GetNumberOfPoints()));
    for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i) pd->GetPoint(i, pts[std::size_t(i)].data());
    return pts;
}

void addCells(InputData& data, vtkPolyData* pd, const std::string& path) {
    vtkCellArray* polys = pd->GetPolys();
    auto ids = vtkSmartPointer<vtkIdList>::New();
    polys->InitTraversal();
    const vtkIdType nv = pd->GetNumberOfPoints();
    while (polys->GetNextCell(ids)) {
        std::vector<int> corners;
        for (vtkIdType k = 0; k < ids->GetNumberOfIds(); ++k) {
            const vtkIdType c = ids->GetId(k);
            if (c < 0 || c >= nv) fail(path, 0, "face index out of range");
            corners.push_back(int(c));
        }
        if (corners.size() >= 3) addPolygon(data, corners);
    }
}

}  // namespace

InputData readStl(const std::string& path) {
    slurp(path);  // missing / empty checks with our messages
    vtkObject::GlobalWarningDisplayOff();
    auto reader = vtkSmartPointer<vtkSTLReader>::New();
    reader->MergingOff();  // a soup: keep each triangle's own corners
    vtkPolyData* pd = run(reader.Get(), path, "STL");
    InputData data;
    data.soup.emplace();
    data.soup->vertices = pointsOf(pd);
    addCells(data, pd, path);
    return data;
}

InputData readVtp(const std::string& path) {
    slurp(path);
    vtkObject::GlobalWarningDisplayOff();
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    vtkPolyData* pd = run(reader.Get(), path, "VTP (VTK XML PolyData)");
    InputData data;
    if (pd->GetNumberOfPolys() > 0) {
        data.soup.emplace();
        data.soup->vertices = pointsOf(pd);
        addCells(data, pd, path);
        return data;
    }
    data.cloud.emplace();
    data.cloud->positions = pointsOf(pd);
    vtkPointData* attrs = pd->GetPointData();
    vtkDataArray* normals = attrs->GetNormals() ? attrs->GetNormals() : attrs->GetArray("Normals");
    if (normals && normals->GetNumberOfComponents() == 3)
        for (vtkIdType i = 0; i < normals->GetNumberOfTuples(); ++i) {
            double* n = normals->GetTuple3(i);
            data.cloud->normals.emplace_back(n[0], n[1], n[2]);
        }
    if (vtkDataArray* s = attrs->GetArray("sigma"); s && s->GetNumberOfComponents() == 1)
        for (vtkIdType i = 0; i < s->GetNumberOfTuples(); ++i) data.cloud->sigmas.push_back(s->GetTuple1(i));
    if (vtkDataArray* a = attrs->GetArray("area"); a && a->GetNumberOfComponents() == 1)
        for (vtkIdType i = 0; i < a->GetNumberOfTuples(); ++i) data.cloud->areas.push_back(a->GetTuple1(i));
    return data;
}

}  // namespace gpisvdb::detail
