// pipetile — pyopenvdb grids in the Python module, through Boost.Python.
//
// pyopenvdb.h's getGridFromPyObject lives in the pyopenvdb extension module, which nothing can
// link against; it is a Boost.Python extraction, and Boost.Python's converter registry is shared
// through libboost_python, so the same extraction here finds the FloatGrid class pyopenvdb
// registered. The grid is extracted by reference, not as a shared_ptr: Boost.Python's shared_ptr
// holds a Python reference, which must not be dropped without the GIL.

#include "pyopenvdb_grid.h"

#include <pipetile/volume_grid.h>

#include <boost/python.hpp>

namespace pipetile::python {

Volume volumeFromPyOpenVdb(PyObject* grid, const VolumeOptions& options)
{
    namespace bp = boost::python;
    openvdb::FloatGrid::Ptr copy;
    {
        const bp::object object{bp::handle<>(bp::borrowed(grid))};
        bp::extract<openvdb::FloatGrid&> floatGrid(object);
        if (!floatGrid.check()) return {};
        copy = floatGrid().deepCopy();
    }
    PyThreadState* released = PyEval_SaveThread();
    try {
        Volume volume = volumeFromGrid(copy, options, "pyopenvdb grid");
        PyEval_RestoreThread(released);
        return volume;
    } catch (...) {
        PyEval_RestoreThread(released);
        throw;
    }
}

} // namespace pipetile::python
