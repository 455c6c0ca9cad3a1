#include "gpisvdb/tasks/spectrum.h"

#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"

namespace gpisvdb {

Eigen::VectorXd massVector(const Band& band) {
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    Eigen::VectorXd m(Eigen::Index(band.size()));
    for (std::size_t i = 0; i < band.size(); ++i) m(Eigen::Index(i)) = h3 * double(band.mu[i]);
    return m;
}

EigenResult spectrum(const Band& band, const EigenOptions& options, const Progress& progress) {
    if (band.size() == 0) throw InputError("the band is empty");
    progress.update("assemble L", 0);
    const SparseMatrixD L = assembleLaplacianDouble(band);
    return lowestEigenpairs(L, massVector(band), options, progress);
}

}  // namespace gpisvdb
