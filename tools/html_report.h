// pipetile — the HTML report of `mesh`, `validate` and `bench` (`--html`): one self-contained page
// (web/src/report.html, its script bundled from web/src/report.js) with the levels as an embedded
// .glb, their table, and for bench the error against the triangle count of pipetile and its peers.
#pragma once

#include <pipetile/gltf.h>
#include <pipetile/mesh_io.h>
#include <pipetile/multires.h>
#include <pipetile/output_set.h>

#include <nlohmann/json.hpp>

#include <string>

namespace pipetile::tools {

/// The page template with its script inlined, compiled in from the build folder; empty when npm
/// was not there to build it (cmake/embed_report.cmake).
extern const char* const kReportPage;

/// @throw Error naming `path` if this pipetile was built without the page (no npm at build time).
void checkHtmlReportAvailable(const std::string& path);

/// Level `level` of `nested` as a mesh of its own: the prefix of the vertices it uses and its
/// triangles, the same mesh as the level's up to the numbering of its vertices.
TriangleMesh nestedMesh(const NestedLevels& nested, std::size_t level);

/// The page's data. `levels`: per level the report's fields ("level", "rays", "vertices",
/// "triangles", "seconds", optional "validation", "euler", "components", "name"); `peers`: bench's
/// peer rows, or null. `voxel` in world units scales the error colours (red at one voxel).
struct HtmlReport {
    std::string title, subtitle;
    nlohmann::json levels = nlohmann::json::array();
    nlohmann::json peers; // null: no plot
    double voxel = 1.0;
};

/// Writes the page as `path`, a target of `outputs`, with `nested` embedded as a .glb (base64).
/// @throw Error as checkHtmlReportAvailable and OutputSet::write.
void writeHtmlReport(OutputSet& outputs, const std::string& path, const HtmlReport& report, const NestedLevels& nested,
                     const GlbOptions& glb);

} // namespace pipetile::tools
