// pipetile — pyopenvdb grids in the Python module, through Boost.Python (Debian's python3-openvdb
// 10 is a Boost.Python module); the only translation unit that includes Boost.Python.
#pragma once

#include <pipetile/volume.h>

struct _object; // PyObject, without Python.h

namespace pipetile::python {

/// A Volume from a pyopenvdb.FloatGrid: the grid is deep-copied while the caller holds the GIL,
/// so Python may change or drop its grid while the copy is meshed; the checks run without the GIL.
/// Returns an invalid Volume if `grid` is no FloatGrid that this process's Boost.Python knows (not
/// a pyopenvdb object, another grid type, or a pyopenvdb from a build without Boost.Python).
/// @throw Error as volumeFromGrid.
Volume volumeFromPyOpenVdb(_object* grid, const VolumeOptions& options);

} // namespace pipetile::python
