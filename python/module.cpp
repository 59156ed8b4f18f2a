// pipetile — the Python extension `pipetile._pipetile` (pybind11); pipetile/__init__.py is its
// Python face. The only translation unit that includes pybind11; OpenVDB stays out of it.
//
// Every call releases the GIL while the library works. Arrays leave without a copy: numpy takes
// the library's vectors over, through a capsule that frees them with the array.

#include "embed.h"
#include "frame.h"
#include "pyopenvdb_grid.h"
#include "report.h"
#include "sequence.h"

#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/validate.h>
#include <pipetile/volume.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;

namespace pipetile::python {

namespace {

static_assert(sizeof(glm::dvec3) == 3 * sizeof(double), "vertices are handed to numpy as (N, 3) doubles");
static_assert(sizeof(Triangle) == 3 * sizeof(std::int32_t), "faces are handed to numpy as (M, 3) int32");

// A (rows, 3) numpy array over a vector's memory; the array owns the vector from now on.
template <typename Out, typename T>
py::array_t<Out> handOver(std::vector<T> vector)
{
    auto* owned = new std::vector<T>(std::move(vector));
    const py::capsule free(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    const py::ssize_t rows = static_cast<py::ssize_t>(owned->size());
    return py::array_t<Out>({rows, py::ssize_t(3)}, {py::ssize_t(3 * sizeof(Out)), py::ssize_t(sizeof(Out))},
                            reinterpret_cast<const Out*>(owned->data()), free);
}

// Bytes from the library (a path, a grid's name, a message naming them) as Python's str, the way
// os.fsdecode makes one: bytes that are no UTF-8 (a Latin-1 file name) become surrogates, which
// os.fsencode turns back into the same bytes, where pybind11's strict decoding raised.
py::str text(const std::string& bytes)
{
    PyObject* decoded = PyUnicode_DecodeUTF8(bytes.data(), static_cast<Py_ssize_t>(bytes.size()), "surrogateescape");
    if (!decoded) throw py::error_already_set();
    return py::reinterpret_steal<py::str>(decoded);
}

py::list texts(const std::vector<std::string>& bytes)
{
    py::list out;
    for (const std::string& b : bytes) out.append(text(b));
    return out;
}

Axis parseAxis(const std::string& axis)
{
    if (axis == "x") return Axis::X;
    if (axis == "y") return Axis::Y;
    if (axis == "z") return Axis::Z;
    if (axis == "auto") return Axis::Auto;
    throw UsageError("axis '" + axis + "': use 'x', 'y', 'z' or 'auto'");
}

TilerKind parseTiler(const std::string& tiler)
{
    if (tiler == "contour-tree") return TilerKind::ContourTree;
    if (tiler == "optimal") return TilerKind::Optimal;
    if (tiler == "greedy") return TilerKind::Greedy;
    throw UsageError("tiler '" + tiler + "': use 'contour-tree', 'optimal' or 'greedy'");
}

VolumeOptions volumeOptions(const std::string& grid, std::optional<double> iso)
{
    VolumeOptions options;
    options.gridName = grid;
    options.iso = iso;
    return options;
}

Volume readFile(const std::string& path, const std::string& grid, std::optional<double> iso)
{
    const py::gil_scoped_release release;
    return readVolume(path, volumeOptions(grid, iso));
}

using DenseArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

Volume readDense(const DenseArray& values, const py::array_t<double, py::array::c_style | py::array::forcecast>& matrix,
                 bool levelSet, const std::string& grid, std::optional<double> iso, const std::string& source)
{
    if (values.ndim() != 3)
        throw UsageError("a dense volume is a 3-D array; got " + std::to_string(values.ndim()) + " dimensions");
    if (matrix.ndim() != 2 || matrix.shape(0) != 4 || matrix.shape(1) != 4)
        throw UsageError("index_to_world must be a 4x4 matrix");
    for (int a = 0; a < 3; ++a)
        if (values.shape(a) > std::numeric_limits<int>::max())
            throw UsageError("a dense volume is at most 2^31 - 1 voxels along each axis");
    DenseVolume dense;
    dense.values = values.data();
    dense.dims = {int(values.shape(0)), int(values.shape(1)), int(values.shape(2))};
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) dense.indexToWorld[c][r] = matrix.at(r, c);
    dense.volumeClass = levelSet ? VolumeClass::LevelSet : VolumeClass::Fog;
    const py::gil_scoped_release release;
    return volumeFromDense(dense, volumeOptions(grid, iso), source);
}

// None if the object is no FloatGrid the Boost.Python bridge reads.
std::optional<Volume> readPyOpenVdb(const py::object& grid, std::optional<double> iso)
{
    Volume volume = volumeFromPyOpenVdb(grid.ptr(), volumeOptions("", iso));
    if (!volume.valid()) return std::nullopt;
    return volume;
}

MeshOptions meshOptions(const std::string& axis, double spacing, int rays, int levels, bool everySlice, int threads,
                        const std::string& tiler)
{
    MeshOptions options;
    options.slicing.axis = parseAxis(axis);
    options.slicing.spacingVoxels = spacing;
    options.baseRays = rays;
    options.levels = levels;
    options.everySlice = everySlice;
    options.threads = threads;
    options.tiler = parseTiler(tiler);
    return options;
}

// (vertices (N, 3) float64, [vertex count per level], [faces (M, 3) int32 per level], report JSON).
py::tuple mesh(const Volume& volume, const std::string& axis, double spacing, int rays, int levels, bool everySlice,
               int threads, const std::string& tiler)
{
    const MeshOptions options = meshOptions(axis, spacing, rays, levels, everySlice, threads, tiler);
    MeshedLevels meshed;
    {
        const py::gil_scoped_release release;
        meshed = meshLevels(volume, options);
    }
    if (meshed.levels.vertices.size() > std::size_t(std::numeric_limits<std::int32_t>::max()))
        throw Error("the finest level has " + std::to_string(meshed.levels.vertices.size()) +
                    " vertices, more than int32 faces can index; lower levels or rays");
    py::list faces;
    for (std::vector<Triangle>& triangles : meshed.levels.triangles)
        faces.append(handOver<std::int32_t>(std::move(triangles)));
    return py::make_tuple(handOver<double>(std::move(meshed.levels.vertices)), meshed.levels.vertexCounts, faces,
                          meshed.report);
}

// (report JSON, [notes]) of one input meshed into its files, as `pipetile mesh` writes them.
py::tuple meshToFiles(const std::string& input, const std::string& output, const std::string& report,
                      const std::string& grid, std::optional<double> iso, const std::string& axis, double spacing,
                      int rays, int levels, bool everySlice, int threads, const std::string& tiler)
{
    const MeshOptions options = meshOptions(axis, spacing, rays, levels, everySlice, threads, tiler);
    MeshedFiles meshed;
    {
        const py::gil_scoped_release release;
        meshed = meshFiles(input, output, report, volumeOptions(grid, iso), options);
    }
    return py::make_tuple(meshed.report, texts(meshed.notes));
}

tools::FramePattern framePattern(const std::string& text, const char* what)
{
    std::optional<tools::FramePattern> pattern = tools::FramePattern::parse(text);
    if (!pattern)
        throw UsageError(std::string(what) + " '" + text + "' holds no frame number; write it as ####, $F4 or %04d");
    return *pattern;
}

std::vector<int> sequenceFrames(const std::string& pattern, const std::string& range)
{
    return range.empty() ? framePattern(pattern, "the input").existingFrames() : tools::parseFrameRange(range);
}

std::string sequenceReport(const std::string& input, const std::string& output, const std::string& outcomes,
                           double seconds)
{
    std::vector<tools::FrameOutcome> frames;
    for (const nlohmann::json& o : nlohmann::json::parse(outcomes))
        frames.push_back({o["frame"].get<int>(), o["input"].get<std::string>(), o["status"].get<std::string>(),
                          o.value("error", std::string()), o.value("report", nlohmann::json())});
    return tools::reportText(tools::sequenceReport(input, output, frames, seconds));
}

std::string validate(const Volume& volume,
                     const py::array_t<double, py::array::c_style | py::array::forcecast>& vertices,
                     const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& faces, int threads)
{
    if (vertices.ndim() != 2 || vertices.shape(1) != 3) throw UsageError("vertices must be an (N, 3) array");
    if (faces.ndim() != 2 || faces.shape(1) != 3) throw UsageError("faces must be an (M, 3) array of vertex indices");
    TriangleMesh mesh;
    mesh.vertices.resize(static_cast<std::size_t>(vertices.shape(0)));
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
        mesh.vertices[v] = {vertices.at(v, 0), vertices.at(v, 1), vertices.at(v, 2)};
    mesh.triangles.resize(static_cast<std::size_t>(faces.shape(0)));
    const std::int64_t count = vertices.shape(0);
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t id = faces.at(t, k);
            if (id < 0 || id >= count)
                throw UsageError("face " + std::to_string(t) + " names vertex " + std::to_string(id) +
                                 ", but there are " + std::to_string(count) + " vertices");
            mesh.triangles[t][k] = static_cast<std::uint32_t>(id);
        }
    const py::gil_scoped_release release;
    return validateMesh(volume, mesh, threads);
}

void bindErrors(py::module_& m)
{
    // UsageError is both: a pipetile.Error, and the ValueError Python code expects for bad arguments.
    static py::exception<Error> error(m, "Error");
    static py::exception<UsageError> usageError(m, "UsageError", py::make_tuple(error, py::handle(PyExc_ValueError)));
    py::register_exception_translator([](std::exception_ptr thrown) {
        try {
            if (thrown) std::rethrow_exception(thrown);
        } catch (const UsageError& e) {
            PyErr_SetObject(usageError.ptr(), text(withSettings(e, "", "=")).ptr());
        } catch (const Error& e) {
            PyErr_SetObject(error.ptr(), text(withSettings(e, "", "=")).ptr());
        }
    });
}

} // namespace

} // namespace pipetile::python

PYBIND11_MODULE(_pipetile, m)
{
    using namespace pipetile;
    using namespace pipetile::python;
    m.doc() = "pipetile's C++ core; use the pipetile package, not this module";
    bindErrors(m);

    py::class_<Volume>(m, "Volume", "A scalar float grid with its class and isovalue, ready to mesh")
        .def_property_readonly("source", [](const Volume& v) { return text(v.source()); })
        .def_property_readonly("grid", [](const Volume& v) { return text(v.gridName()); })
        .def_property_readonly("grid_class", [](const Volume& v) { return toString(v.volumeClass()); })
        .def_property_readonly("iso", &Volume::iso)
        .def_property_readonly("voxel_size", [](const Volume& v) {
            const glm::dvec3 s = v.voxelSize();
            return py::make_tuple(s.x, s.y, s.z);
        });

    m.def("read_volume", &readFile, py::arg("path"), py::arg("grid"), py::arg("iso"));
    m.def("dense_volume", &readDense, py::arg("values"), py::arg("index_to_world"), py::arg("level_set"),
          py::arg("grid"), py::arg("iso"), py::arg("source"));
    m.def("pyopenvdb_volume", &readPyOpenVdb, py::arg("grid"), py::arg("iso"));
    m.def("mesh", &mesh, py::arg("volume"), py::arg("axis"), py::arg("spacing"), py::arg("rays"), py::arg("levels"),
          py::arg("every_slice"), py::arg("threads"), py::arg("tiler"));
    m.def("mesh_to_files", &meshToFiles, py::arg("input"), py::arg("output"), py::arg("report"), py::arg("grid"),
          py::arg("iso"), py::arg("axis"), py::arg("spacing"), py::arg("rays"), py::arg("levels"),
          py::arg("every_slice"), py::arg("threads"), py::arg("tiler"));
    m.def(
        "frame_path",
        [](const std::string& pattern, int frame) { return text(framePattern(pattern, "the pattern").path(frame)); },
        py::arg("pattern"), py::arg("frame"));
    m.def("sequence_frames", &sequenceFrames, py::arg("pattern"), py::arg("range"));
    m.def("outputs_exist", &tools::outputsExist, py::arg("output"), py::arg("report"), py::arg("levels"));
    m.def(
        "frame_error", [](int frame, const std::string& what) { return text(tools::frameError(frame, what)); },
        py::arg("frame"), py::arg("what"));
    m.def("sequence_report", &sequenceReport, py::arg("input"), py::arg("output"), py::arg("outcomes"),
          py::arg("seconds"));
    m.def("validate", &validate, py::arg("volume"), py::arg("vertices"), py::arg("faces"), py::arg("threads"));
}
