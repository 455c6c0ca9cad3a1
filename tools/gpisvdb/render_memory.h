#pragma once
// What an offscreen VTK render holds beside its surfaces (gpisvdb render, the demo's pictures): measured constants
// (docs/memory.md#render), one machine's (Mesa llvmpipe, 2 cores): another driver or more cores change them.
#include <string>
#include <utility>
#include <vector>

namespace gpisvdb::cli {

/// Offscreen rendering, bytes per pixel: 8 multisamples of RGBA and depth (64 bytes), the resolved window and the
/// PNG rows (measured: 83–88, docs/memory.md#render).
constexpr double kRenderBytesPerPixel = 80;
/// What a render adds whatever its size, bytes: the OpenGL driver's state (Mesa's llvmpipe, its threads and
/// compiled shaders), VTK's render window, colour bar and text; measured (docs/memory.md#render).
constexpr double kRenderContextBytes = 90e6;
/// What VTK and the driver hold per surface vertex shown in a panel, bytes: the normals filter's output, the
/// mapper's colours and the vertex and index buffers the driver keeps; measured (docs/memory.md#render).
constexpr double kRenderBytesPerVertex = 820;

/// A render's parts beside its surfaces' own arrays: `panelVertices` surface vertices summed over the panels that
/// show them (vtk_surface), the context (gl_context) and `pixels` over all panels (window), bytes.
inline std::vector<std::pair<std::string, double>> renderBytes(double panelVertices, double pixels) {
    return {{"vtk_surface", panelVertices * kRenderBytesPerVertex},
            {"gl_context", kRenderContextBytes},
            {"window", pixels * kRenderBytesPerPixel}};
}

}  // namespace gpisvdb::cli
