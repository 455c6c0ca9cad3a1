#include "gpisvdb/model/gpis_model.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gpisvdb {

std::vector<ValueGradient> GpisModel::evaluate(const std::vector<Vec3d>& xs, const Progress& progress) const {
    std::vector<ValueGradient> out(xs.size());
    // Blocks keep progress and interruption on the calling thread; each point is independent, so the
    // result does not depend on how TBB splits the work.
    constexpr std::size_t kBlock = 8192;
    for (std::size_t b = 0; b < xs.size(); b += kBlock) {
        progress.checkInterrupt();
        progress.update("evaluate", double(b) / double(xs.size()));
        const std::size_t e = std::min(xs.size(), b + kBlock);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 16), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                progress.checkInterruptAt(i);
                out[i] = evaluate(xs[i]);
            }
        });
    }
    progress.update("evaluate", 1.0);
    return out;
}

}  // namespace gpisvdb
