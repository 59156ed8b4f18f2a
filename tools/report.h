// pipetile — the JSON report of `pipetile mesh` and `pipetile validate` (README, "The report"),
// built in one place for the CLI and the Python module, so both give the same fields.
#pragma once

#include <pipetile/multires.h>
#include <pipetile/validate.h>
#include <pipetile/volume.h>

#include <nlohmann/json.hpp>

namespace pipetile::tools {

const char* axisName(int axis);        // "x", "y", "z"
const char* tilerName(TilerKind kind); // "contour-tree", "optimal", "greedy"

/// The report of `pipetile mesh` without its levels and its total "seconds": the volume, the
/// options, the reconstruction's statistics, events and skeleton graph; "levels" is an empty array.
nlohmann::json meshReport(const Volume& volume, const Reconstruction& reconstruction);

/// One entry of the report's "levels", without "file": what the level took and holds. With
/// `topology`, also the level's own Euler characteristic and components (a linear pass).
nlohmann::json levelReport(const LevelMesh& level, bool topology);

/// The validation block: distances in world units and voxels, topology, area, volume, quality.
nlohmann::json validationReport(const Validation& validation);

/// A report as JSON text (`indent` as nlohmann's dump). Paths and grid names are bytes, not always
/// UTF-8 (a file named in Latin-1, a grid name from a damaged file): such bytes become U+FFFD, as
/// JSON must be UTF-8, where dump's default would throw and lose the run's outputs.
std::string reportText(const nlohmann::json& report, int indent = -1);

} // namespace pipetile::tools
