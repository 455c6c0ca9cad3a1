#pragma once
// The GPIS Laplacian of a distributed band as a PETSc matrix (docs/mpi.md#solvers): rows in the band's linear order,
// each rank its own range (MATMPIAIJ), assembled from the Selling stencils exactly as assembleLaplacian (ops/
// laplacian.h) assembles the one-process matrix, in double.
#include <petscmat.h>

#include <cstdint>
#include <vector>

#include "gpisvdb/mpi/distributed_band.h"

namespace gpisvdb::mpi {

/// Calls PETSc's error handler to return codes (no trace on stderr); call once after PetscInitialize.
void quietPetscErrors();

/// Throws Error naming `what` and PETSc's message when code ≠ 0.
void checkPetsc(PetscErrorCode code, const char* what);

/// Linear index (in the whole band) of x ± h e_k for each local voxel's stencil terms, at [12 i + 2 k + s] (s = 0:
/// +e_k, s = 1: −e_k); −1 outside the band or beyond the voxel's term count. Indices held by other ranks are asked
/// of them (one exchange each way). Collective.
std::vector<std::int64_t> globalStencilNeighbours(const Ranks& ranks, const DistributedBand& band);

/// A PETSc matrix, destroyed with its owner.
class PetscMatrix {
public:
    PetscMatrix() = default;
    explicit PetscMatrix(Mat m) : m_(m) {}
    PetscMatrix(PetscMatrix&& o) noexcept : m_(o.m_) { o.m_ = nullptr; }
    PetscMatrix& operator=(PetscMatrix&& o) noexcept;
    PetscMatrix(const PetscMatrix&) = delete;
    PetscMatrix& operator=(const PetscMatrix&) = delete;
    ~PetscMatrix();
    Mat get() const { return m_; }

private:
    Mat m_ = nullptr;
};

struct PetscLaplacian {
    PetscMatrix L;
    std::size_t ghosts = 0;  ///< unknowns of other ranks this rank reads in a product (its halo)
};

/// L of the whole band (paper Eq. 22: each edge (x, x ± h e_k) of a voxel's stencil carries h λ_k / 2, added to both
/// ends; an edge leaving the band adds to the diagonal only), entries summed in double. Collective.
PetscLaplacian assembleLaplacianPetsc(const Ranks& ranks, const DistributedBand& band);

}  // namespace gpisvdb::mpi
