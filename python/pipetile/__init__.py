"""pipetile: multiresolution triangle meshes of pipe-shaped objects (vessels, airways, pipes,
tubes) from OpenVDB volumes, after Min & Lee.

    import pipetile
    levels = pipetile.mesh("vessel.vdb", levels=4)       # or a numpy volume, or a pyopenvdb grid
    finest = levels[-1]                                   # finest.vertices, finest.faces
    print(len(finest.faces), levels.report["levels"][0]["triangles"])
    pipetile.validate("vessel.vdb", finest.vertices, finest.faces)["hausdorff_voxels"]

The levels nest: every vertex of level L is a vertex of level L + 1, bit for bit. The vertices are
therefore ordered coarse-first in one array, ``levels.vertices`` (the finest level's): level L's
vertices are its first ``levels[L].vertex_count``, and ``levels[L].vertices`` is that prefix, a
view. Faces are (M, 3) int32 indices into it, counterclockwise seen from outside.

Errors are ``pipetile.Error`` with the library's message (naming the file or grid and what to do);
bad arguments are ``pipetile.UsageError``, which is both a ``pipetile.Error`` and a ``ValueError``.
"""

import collections.abc
import json
import math
import os

import numpy as np

from . import _pipetile
from ._pipetile import Error, UsageError

__all__ = ["mesh", "validate", "Levels", "Level", "Error", "UsageError"]


class Level:
    """One level of detail: ``vertices`` (vertex_count, 3) float64 in world space, a view of the
    shared coarse-first array; ``faces`` (M, 3) int32; ``report``, the level's entry of the report."""

    __slots__ = ("level", "vertices", "faces", "vertex_count", "report")

    def __init__(self, level, vertices, faces, vertex_count, report):
        self.level = level
        self.vertices = vertices
        self.faces = faces
        self.vertex_count = vertex_count
        self.report = report

    def as_tuple(self):
        """(vertices, faces), as trimesh.Trimesh(*t), igl and open3d take them."""
        return self.vertices, self.faces

    def to_meshio(self):
        """The level as a meshio.Mesh (meshio is imported here, only when asked for)."""
        import meshio

        return meshio.Mesh(self.vertices, [("triangle", self.faces)])

    def __repr__(self):
        return f"<pipetile.Level {self.level}: {self.vertex_count} vertices, {len(self.faces)} triangles>"


class Levels(collections.abc.Sequence):
    """The levels of detail of one volume, coarsest first, over one vertex array.

    ``vertices``: (N, 3) float64, world space, the finest level's, ordered coarse-first; read-only,
    because every level shares it. ``vertex_counts``: level L's vertices are the first
    vertex_counts[L]. ``report``: the dict ``pipetile mesh --report`` writes (no "file" entries)."""

    def __init__(self, vertices, vertex_counts, faces, report):
        vertices.flags.writeable = False
        self.vertices = vertices
        self.vertex_counts = list(vertex_counts)
        self.report = report
        self._levels = [
            Level(k, vertices[:count], faces[k], count, report["levels"][k])
            for k, count in enumerate(self.vertex_counts)
        ]

    def __getitem__(self, index):
        return self._levels[index]

    def __len__(self):
        return len(self._levels)

    def __repr__(self):
        counts = ", ".join(str(len(level.faces)) for level in self._levels)
        return f"<pipetile.Levels of {self.report['input']!r}: triangles {counts}>"


def mesh(source, *, grid=None, iso=None, axis="auto", spacing=2.0, rays=8, levels=4, every_slice=False,
         threads=0, tiler="contour-tree", voxel_size=None, origin=None, index_to_world=None, grid_class=None):
    """Meshes a volume into ``levels`` levels of detail, as ``pipetile mesh`` does; returns Levels.

    ``source`` is a .vdb path (``grid`` picks a grid by name, default the first float grid), a
    pyopenvdb.FloatGrid (copied, so Python may change it meanwhile), or a dense 3-D numpy volume,
    where array[i, j, k] is voxel (i, j, k). A numpy volume needs ``grid_class`` ("level set" or
    "fog") and is placed in world space by ``voxel_size`` (a number or three, default 1) and
    ``origin`` (world position of voxel [0, 0, 0], default 0), or by ``index_to_world``, a 4x4
    matrix M with world = M @ (i, j, k, 1) (nibabel's affine). Its background, the value of empty
    space, is its largest value for a level set and its smallest for fog.

    ``iso``: default 0 for level sets, halfway from the background to the largest value for fog.
    ``axis`` "x", "y", "z" or "auto"; ``spacing`` between slices in voxels; ``rays`` at level 0,
    doubling at each level; ``every_slice`` tiles every slice at every level; ``threads`` 0 uses
    every core; ``tiler`` "contour-tree" (the paper's), or the baselines "optimal" and "greedy".
    The work runs without the GIL.
    """
    volume = _volume(source, grid, iso, voxel_size, origin, index_to_world, grid_class)
    vertices, counts, faces, report = _pipetile.mesh(volume, axis, spacing, rays, levels, every_slice, threads, tiler)
    return Levels(vertices, counts, faces, json.loads(report))


def validate(source, vertices, faces, *, grid=None, iso=None, threads=0, voxel_size=None, origin=None,
             index_to_world=None, grid_class=None):
    """Compares a mesh with the isosurface of ``source`` (as in mesh) found by OpenVDB's
    volumeToMesh; returns the dict ``pipetile validate --report`` holds under "validation":
    distances in world units and voxels, topology, area, volume and triangle quality."""
    volume = _volume(source, grid, iso, voxel_size, origin, index_to_world, grid_class)
    return json.loads(_pipetile.validate(volume, vertices, faces, threads))


_CLASSES = {"level set": True, "fog": False, "fog volume": False}


def _volume(source, grid, iso, voxel_size, origin, index_to_world, grid_class):
    placement = {"voxel_size": voxel_size, "origin": origin, "index_to_world": index_to_world,
                 "grid_class": grid_class}
    if isinstance(source, (str, bytes, os.PathLike)):
        _refuse(placement, "a .vdb file carries its own transform and class")
        return _pipetile.read_volume(os.fsencode(source), _name(grid), iso)
    if type(source).__module__ == "pyopenvdb":
        _refuse(placement, "a pyopenvdb grid carries its own transform and class")
        if grid is not None:
            raise UsageError("grid= picks a grid of a .vdb file or names a numpy volume; a pyopenvdb grid is one grid")
        volume = _pipetile.pyopenvdb_volume(source, iso)
        if volume is None:
            raise UsageError(f"pyopenvdb.{type(source).__name__} {getattr(source, 'name', '')!r}: pipetile meshes "
                             "a pyopenvdb.FloatGrid of Debian's python3-openvdb; pass other grids as numpy volumes "
                             "(grid.copyToArray)")
        return volume
    return _dense_volume(source, grid, iso, voxel_size, origin, index_to_world, grid_class)


def _refuse(placement, why):
    given = [name for name, value in placement.items() if value is not None]
    if given:
        raise UsageError(f"{', '.join(given)} apply to numpy volumes only; {why}")


def _dense_volume(source, grid, iso, voxel_size, origin, index_to_world, grid_class):
    values = np.asarray(source)
    if not (np.issubdtype(values.dtype, np.floating) or np.issubdtype(values.dtype, np.integer)):
        raise UsageError(f"a numpy volume holds real numbers; got dtype {values.dtype} "
                         f"(or pass a .vdb path or a pyopenvdb.FloatGrid, not {type(source).__name__})")
    if values.ndim != 3:
        raise UsageError(f"a numpy volume is a 3-D array; got shape {values.shape}")
    if grid_class not in _CLASSES:
        raise UsageError(f"grid_class={grid_class!r}: a numpy volume needs grid_class='level set' (signed "
                         "distance, negative inside) or 'fog' (density, larger inside)")
    matrix = _index_to_world(voxel_size, origin, index_to_world)
    source_name = "numpy array " + "x".join(str(n) for n in values.shape)
    return _pipetile.dense_volume(values, matrix, _CLASSES[grid_class], _name(grid), iso, source_name)


def _name(grid):
    """A grid's name as the library takes it, bytes: a str as os.fsencode makes them, so that a name
    read back from Volume.grid (bytes that are no UTF-8 kept as surrogates) picks the same grid."""
    return os.fsencode(grid or "")


def _index_to_world(voxel_size, origin, index_to_world):
    if index_to_world is not None:
        if voxel_size is not None or origin is not None:
            raise UsageError("give index_to_world, or voxel_size and origin, not both")
        matrix = np.asarray(index_to_world, dtype=np.float64)
        if matrix.shape != (4, 4):
            raise UsageError(f"index_to_world must be a 4x4 matrix; got shape {matrix.shape}")
        return matrix
    size = np.asarray(1.0 if voxel_size is None else voxel_size, dtype=np.float64)
    size = np.full(3, size) if size.shape == () else size
    if size.shape != (3,) or not all(math.isfinite(s) and s > 0 for s in size):
        raise UsageError(f"voxel_size={voxel_size!r}: a positive number, or three")
    corner = np.asarray((0.0, 0.0, 0.0) if origin is None else origin, dtype=np.float64)
    if corner.shape != (3,) or not np.all(np.isfinite(corner)):
        raise UsageError(f"origin={origin!r}: the world position (x, y, z) of voxel [0, 0, 0]")
    matrix = np.diag([size[0], size[1], size[2], 1.0])
    matrix[:3, 3] = corner
    return matrix
