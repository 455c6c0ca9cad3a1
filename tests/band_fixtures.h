#pragma once
// Small bands shared by the operator, solver, task and output tests (built once per test process).
#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/model/barnes_hut_gpis.h"

namespace gpisvdb::test {

inline Band bandOf(const TriangleSoup& soup, double sigmaRel, double voxelSize) {
    const SoupSamples ss = soupSamples(soup, {sigmaRel});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    BandOptions o;
    o.voxelSize = voxelSize;
    return buildBand(model, ss.samples, o).band;
}

/// Unit sphere (320 triangles), σ_rel = 1, h = 0.08: about 13 000 voxels.
inline const Band& sphereBand() {
    static const Band band = bandOf(icosphere(2), 1.0, 0.08);
    return band;
}

/// Torus (ring 1, tube 0.4) with its top cut away, σ_rel = 1, h = 0.06.
inline const Band& torusGapBand() {
    static const Band band = bandOf(cutAbove(torus(48, 16), 0.25), 1.0, 0.06);
    return band;
}

}  // namespace gpisvdb::test
