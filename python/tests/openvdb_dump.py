"""Dump a .vdb file as the OpenVDB library reads it (run by an interpreter
that has OpenVDB's Python module: Debian's python3-openvdb under
/usr/bin/python3, which needs that system's NumPy 1.x, hence a separate
process rather than an import into the tests' venv).

    python3 openvdb_dump.py FILE.vdb NX NY NZ OUT_DIR

writes OUT_DIR/meta.json (the file's metadata; per grid its name, type,
class, vector type, voxel size, where index (0,0,0) and (1,2,3) lie in the
world, background, active voxel count and metadata) and OUT_DIR/<grid>.npy,
each grid's values over the index box [0, NX) × [0, NY) × [0, NZ) as
OpenVDB's copyToArray gives them: ``a[i, j, k]`` is voxel (x=i, y=j, z=k).
"""

import json
import sys

import numpy as np

try:
    import openvdb as vdb  # OpenVDB 11 and later
except ImportError:
    import pyopenvdb as vdb  # OpenVDB 10 (Debian 12)


def plain(value):
    """A metadata value as JSON can hold it."""
    if isinstance(value, (bool, int, float, str)):
        return value
    try:
        return [plain(v) for v in value]
    except TypeError:
        return str(value)


def main(path, nx, ny, nz, out):
    grids, file_meta = vdb.readAll(path)
    meta = {"library": list(vdb.LIBRARY_VERSION), "file": {k: plain(v) for k, v in file_meta.items()}, "grids": []}
    for g in grids:
        vector = isinstance(g, vdb.Vec3SGrid)
        values = np.zeros((nx, ny, nz, 3) if vector else (nx, ny, nz), dtype=np.float32)
        g.copyToArray(values, ijk=(0, 0, 0))
        np.save(f"{out}/{g.name}.npy", values)
        meta["grids"].append({
            "name": g.name,
            "type": type(g).__name__,
            "class": str(g.gridClass),
            "vector_type": str(g.vectorType),
            "voxel_size": list(g.transform.voxelSize()),
            "world_of_000": list(g.transform.indexToWorld((0, 0, 0))),
            "world_of_123": list(g.transform.indexToWorld((1, 2, 3))),
            "background": plain(g.background),
            "active_voxels": g.activeVoxelCount(),
            "metadata": {k: plain(v) for k, v in g.metadata.items()},
        })
    with open(f"{out}/meta.json", "w") as f:
        json.dump(meta, f)


if __name__ == "__main__":
    main(sys.argv[1], *map(int, sys.argv[2:5]), sys.argv[5])
