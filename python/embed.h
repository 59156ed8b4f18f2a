// pipetile — the Python module's work, in C++ free of pybind11 and OpenVDB: meshing a volume into
// nested levels with the CLI's report, and validating a mesh. module.cpp binds it.
#pragma once

#include <pipetile/multires.h>
#include <pipetile/volume.h>

#include <string>
#include <vector>

namespace pipetile::python {

/// Every level of a volume, built as `pipetile mesh` builds them (level 0, then each refined from
/// the one before), over one coarse-first vertex array, with the CLI's JSON report.
struct MeshedLevels {
    NestedLevels levels;
    std::string report; // the report of `pipetile mesh --report`, without files, as JSON text
};

/// @throw UsageError for options out of range; Error as Reconstruction.
MeshedLevels meshLevels(const Volume& volume, const MeshOptions& options);

/// One input meshed into its level files and report (empty: none) as `pipetile mesh` writes them,
/// one transaction (tools::meshFrame): the same bytes as the CLI's. Returns the report as JSON
/// text, and the notes and warnings the CLI would print ("warning: ...").
/// @throw UsageError, Error as tools::meshFrame (nothing is then written).
struct MeshedFiles {
    std::string report;
    std::vector<std::string> notes;
};
MeshedFiles meshFiles(const std::string& input, const std::string& output, const std::string& report,
                      const VolumeOptions& volume, const MeshOptions& options);

/// The validation block of `pipetile validate`'s report, as JSON text.
/// @throw Error if the mesh has no triangles.
std::string validateMesh(const Volume& volume, const TriangleMesh& mesh, int threads);

} // namespace pipetile::python
