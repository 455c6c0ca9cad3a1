// libFuzzer target: what gpisvdb reads from a .vdb (mesh, render, sample, hodge --field): opening the file (every
// grid and the file metadata), grid lookup by name, the float-grid cast, the 'iso' metadata, and the hodge field:
// FILE.vdb[:GRID] split, the vector grid picked, then sampled trilinearly in world space as readField does.
#include <openvdb/tools/Interpolation.h>

#include "fuzz_common.h"
#include "vdb_file.h"

namespace {

template <class F>
void expectRefusal(F&& f) {  // each step on its own: one refusal must not hide the next step
    try {
        f();
    } catch (const gpisvdb::Error&) {
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    using gpisvdb::cli::VdbFile;
    return gpisvdb::fuzz::readAsFile(data, size, ".vdb", [](const std::string& path) {
        const VdbFile file = VdbFile::read(path);
        (void)file.names();
        (void)file.iso();
        expectRefusal([&] { file.grid("no such grid"); });
        for (const auto& g : *file.grids) {
            const std::string name = g->getName();
            expectRefusal([&] { file.grid(name); });
            expectRefusal([&] {
                const auto f = file.floatGrid(name);
                const openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> s(*f);
                (void)s.wsSample(openvdb::Vec3d(0.25, 0.5, 0.75));
            });
        }
        for (const std::string& spec :
             {path, path + ":vel", path + ":" + (file.grids->empty() ? std::string("x") : (*file.grids)[0]->getName())}) {
            expectRefusal([&] {
                const auto [p, name] = VdbFile::splitSpec(spec);
                const auto field = file.vectorGrid(name);
                const openvdb::tools::GridSampler<openvdb::Vec3SGrid, openvdb::tools::BoxSampler> s(*field);
                for (const openvdb::Vec3d x : {openvdb::Vec3d(0), openvdb::Vec3d(0.3, -0.7, 1.1), openvdb::Vec3d(10, 20, -30)})
                    (void)s.wsSample(x);
            });
        }
    });
}
