#pragma once
// What a test can say about a picture without looking at it: size, colours, how much of it is not background.
#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <vtkSmartPointer.h>

#include <set>
#include <string>

namespace gpisvdb::test {

struct PngStats {
    bool readable = false;
    int width = 0, height = 0;
    std::size_t colours = 0;  ///< distinct RGB values
    double nonWhite = 0;      ///< fraction of pixels that are not (near) white
};

inline PngStats pngStats(const std::string& path) {
    PngStats s;
    auto reader = vtkSmartPointer<vtkPNGReader>::New();
    if (!reader->CanReadFile(path.c_str())) return s;
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    int dims[3];
    image->GetDimensions(dims);
    s.width = dims[0], s.height = dims[1];
    const int comps = image->GetNumberOfScalarComponents();
    if (comps < 3 || s.width <= 0 || s.height <= 0) return s;
    s.readable = true;
    std::set<int> colours;
    std::size_t nonWhite = 0;
    const auto* px = static_cast<const unsigned char*>(image->GetScalarPointer());
    for (std::size_t i = 0; i < std::size_t(s.width) * std::size_t(s.height); ++i) {
        const unsigned char* p = px + i * std::size_t(comps);
        colours.insert(p[0] << 16 | p[1] << 8 | p[2]);
        if (p[0] < 245 || p[1] < 245 || p[2] < 245) ++nonWhite;
    }
    s.colours = colours.size();
    s.nonWhite = double(nonWhite) / (double(s.width) * s.height);
    return s;
}

/// Mean of (red − blue) over the rows [y0, y1) × columns [x0, x1) of an image, pixel rows counted from the bottom.
inline double redMinusBlue(const std::string& path, int x0, int x1, int y0, int y1) {
    auto reader = vtkSmartPointer<vtkPNGReader>::New();
    reader->SetFileName(path.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    double sum = 0;
    int n = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const auto* p = static_cast<const unsigned char*>(image->GetScalarPointer(x, y, 0));
            if (p[0] > 245 && p[1] > 245 && p[2] > 245) continue;  // background
            sum += double(p[0]) - double(p[2]);
            ++n;
        }
    return n ? sum / n : 0;
}

}  // namespace gpisvdb::test
