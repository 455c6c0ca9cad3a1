"""gpisvdb: uncertainty-aware geometry processing on Gaussian Process Implicit Surfaces, on OpenVDB.

A noisy triangle soup or oriented point cloud is a distribution of surfaces; gpisvdb builds it in closed form and
computes on it (Genest and Coeurjolly, ACM TOG 2026). This package exposes the C++ engine (docs/python.md):

    >>> import gpisvdb
    >>> model = gpisvdb.Model(V, F, sigma=0.5)          # or Model.from_cloud(P, N), Model.from_file(path)
    >>> model.evaluate(points)                            # dict: mean, gradient, covariance, mu, T
    >>> band = gpisvdb.band(model)                        # band.mu, band.T, band.world, ... as numpy arrays
    >>> g = band.geodesic(source, target)                 # g['distance'], g['paths']
    >>> band.write_vdb('out.vdb', channels={'geodesic': g['distance']})

Units: world units throughout (those of the input); sigma and smoothing are relative to the input's length scale l.
Errors: gpisvdb.InputError, ParameterError, MemoryLimitError (a ParameterError), OutputError, all gpisvdb.Error.
Ctrl-C stops long work with KeyboardInterrupt; the GIL is released while the engine runs.
"""
from ._core import (  # noqa: F401
    EIGEN_MAX_VOXELS,
    Band,
    Error,
    InputError,
    MemoryLimitError,
    Model,
    OutputError,
    ParameterError,
    __version__,
    band,
)



def _pyopenvdb_grids(self, channels=None, vectors=None, half=False, stencils=False):
    """The band's grids as pyopenvdb grids (Debian's python3-openvdb), as write_vdb writes them.

    Returns a dict name -> grid (mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width, then `channels` and
    `vectors` as in write_vdb), each with the band's transform (voxel k centred at voxel_size * k). Goes through a
    temporary .vdb file, so the grids are exactly those of the file. Raises ImportError without pyopenvdb.
    """
    import os
    import tempfile

    import pyopenvdb

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "band.vdb")
        self.write_vdb(path, half=half, stencils=stencils, channels=channels, vectors=vectors)
        grids, _ = pyopenvdb.readAll(path)
    return {g.name: g for g in grids}


Band.pyopenvdb_grids = _pyopenvdb_grids

__all__ = ["EIGEN_MAX_VOXELS", "Band", "Error", "InputError", "MemoryLimitError", "Model", "OutputError", "ParameterError", "band",
           "__version__"]
