// pipetile — the JSON report of `pipetile mesh` and `pipetile validate`.

#include "report.h"

#include <pipetile/validate.h>

#include <cmath>

namespace pipetile::tools {

using nlohmann::json;

namespace {

json distanceJson(const DistanceStats& d, double voxel)
{
    return {{"max", d.max},
            {"mean", d.mean},
            {"rms", d.rms},
            {"max_voxels", d.max / voxel},
            {"mean_voxels", d.mean / voxel},
            {"rms_voxels", d.rms / voxel},
            {"samples", d.samples}};
}

// The skeleton: segments with their ends and extent along the slicing axis (index space), and
// the junctions joining them.
json graphJson(const Reconstruction& reconstruction)
{
    const Skeleton skeleton = reconstruction.skeleton();
    json segments = json::array(), junctions = json::array();
    for (const Skeleton::Segment& s : skeleton.segments)
        segments.push_back({{"hole", s.hole},
                            {"first_w", s.wFirst},
                            {"last_w", s.wLast},
                            {"contours", s.contours},
                            {"bottom", s.bottom},
                            {"top", s.top},
                            {"bottom_junction", s.bottomJunction},
                            {"top_junction", s.topJunction}});
    for (const Skeleton::Junction& j : skeleton.junctions)
        junctions.push_back({{"kind", toString(j.kind)},
                             {"w", j.w},
                             {"crotch_w", j.crotchW},
                             {"single", j.single},
                             {"partners", j.partners}});
    json patches = json::array();
    for (const Skeleton::Patch& p : skeleton.patches)
        patches.push_back({{"w_below", p.wBelow}, {"w_above", p.wAbove}, {"contours", p.contours}, {"euler", p.euler}});
    json unresolved = json::array();
    for (const Skeleton::Unresolved& u : skeleton.unresolved)
        unresolved.push_back({{"w_below", u.wBelow},
                              {"w_above", u.wAbove},
                              {"walls_below", u.wallsBelow},
                              {"holes_below", u.holesBelow},
                              {"walls_above", u.wallsAbove},
                              {"holes_above", u.holesAbove}});
    return {{"segments", segments}, {"junctions", junctions}, {"patches", patches}, {"unresolved", unresolved}};
}

// The planes where the slabs' Euler characteristic parts from the isosurface's (validate.h).
json eulerDifferencesJson(const EulerProfile& isosurface, const Reconstruction& reconstruction)
{
    json changes = json::array();
    const auto plane = [](double w) { return std::isfinite(w) ? json(w) : json(nullptr); };
    for (const EulerDifference& d :
         eulerDifferences(isosurface, reconstruction.graph(), reconstruction.planePositions()))
        changes.push_back({{"w_below", plane(d.wBelow)}, {"w_above", plane(d.wAbove)}, {"difference", d.difference}});
    return changes;
}

} // namespace

const char* axisName(int axis)
{
    return axis == 0 ? "x" : axis == 1 ? "y" : "z";
}

const char* tilerName(TilerKind kind)
{
    return kind == TilerKind::Optimal ? "optimal" : kind == TilerKind::Greedy ? "greedy" : "contour-tree";
}

json meshReport(const Volume& volume, const Reconstruction& reconstruction)
{
    const ReconstructionStats& stats = reconstruction.stats();
    const MeshOptions& options = reconstruction.options();
    const EulerProfile isosurface = reconstruction.cellProfile();
    return {
        {"input", volume.source()},
        {"grid", volume.gridName()},
        {"class", toString(volume.volumeClass())},
        {"iso", volume.iso()},
        {"inside_voxels", volume.insideVoxels()},
        {"hot_voxels", volume.hotVoxels()},
        {"axis", axisName(reconstruction.plan().axis)},
        {"tiler", tilerName(options.tiler)},
        {"every_slice", options.everySlice},
        {"spacing", options.slicing.spacingVoxels},
        {"voxel", volume.smallestVoxel()},
        {"slices", stats.slices},
        {"statistics",
         {{"empty_slices", stats.emptySlices},
          {"contours", stats.contours},
          {"holes", stats.holes},
          {"tubes", stats.tubes},
          {"dropped_small_contours", stats.droppedSmall},
          {"dropped_unwound_contours", stats.droppedUnwound},
          {"dropped_flat_contours", stats.droppedFlat},
          {"end_contours", stats.endContours},
          {"flat_caps", stats.flatCaps},
          {"clipped_caps", stats.clippedCaps},
          {"annular_caps", stats.annularCaps},
          {"caps", stats.caps},
          {"seconds", stats.seconds}}},
        {"events",
         {{"starts", stats.starts},
          {"ends", stats.ends},
          {"forks", stats.forks},
          {"merges", stats.merges},
          {"saddles", stats.saddles},
          {"rims", stats.rims},
          {"waists", stats.waists},
          {"patches", stats.patches},
          {"keyholes", stats.keyholes},
          {"unresolved", stats.unresolvedEvents},
          {"unresolved_junctions", stats.unresolvedJunctions},
          {"planes_added", stats.addedPlanes},
          {"band_planes", stats.bandPlanes},
          {"band_patches", stats.bandPatches},
          {"end_patches", stats.endPatches},
          {"junction_patches", stats.junctionPatches},
          {"cell_matches", stats.cellMatches},
          {"euler", stats.eventEuler},
          {"built_euler", stats.caps - stats.saddles + stats.patchEuler},
          {"isosurface_euler", isosurface.total()},
          {"euler_differences", eulerDifferencesJson(isosurface, reconstruction)}}},
        {"graph", graphJson(reconstruction)},
        {"levels", json::array()},
    };
}

json levelReport(const LevelMesh& level, bool topology)
{
    json j = {
        {"level", level.level},
        {"rays", level.rays},
        {"added_rays", level.addedRays},
        {"vertices", level.mesh.vertices.size()},
        {"triangles", level.mesh.triangles.size()},
        {"seconds", level.seconds},
        {"built_by", level.level == 0 ? "casting every ray" : "refining the previous level"},
        {"casting_seconds", level.castingSeconds},
        {"tiling_seconds", level.tilingSeconds},
        {"quality_seconds", level.qualitySeconds},
        {"tiling_bytes", level.tilingBytes},
        {"contours", level.contours},
        {"skipped_contours", level.skippedContours},
        {"ambiguous_contours", level.ambiguousContours},
        {"ambiguous_sectors", level.ambiguousSectors},
        {"interpolation_fallbacks", level.interpolationFallbacks},
        {"area_junction_parts", level.areaJunctionParts},
        {"area_bands", level.areaBands},
        {"wall_vertices", level.wallVertices},
    };
    // Triangle quality, for the meshers and renderers downstream (a linear pass).
    const TriangleQuality q = measureQuality(level.mesh);
    j["smallest_angle"] = q.smallestAngle;
    j["largest_aspect"] = q.largestAspect;
    j["triangles_below_5_degrees"] = q.needles;
    j["degenerate_triangles"] = q.degenerate;
    j["flips"] = level.flips;
    if (topology) {
        // The level's own Euler characteristic, against the events'.
        const Topology t = checkTopology(level.mesh);
        j["euler"] = t.euler;
        j["components"] = t.components;
    }
    return j;
}

json validationReport(const Validation& v)
{
    const Topology& t = v.topology;
    json j = {
        {"hausdorff", v.symmetric.max},
        {"mean", v.symmetric.mean},
        {"rms", v.symmetric.rms},
        {"voxel", v.voxel},
        {"hausdorff_voxels", v.symmetric.max / v.voxel},
        {"mean_voxels", v.symmetric.mean / v.voxel},
        {"rms_voxels", v.symmetric.rms / v.voxel},
        {"mesh_to_reference", distanceJson(v.meshToReference, v.voxel)},
        {"reference_to_mesh", distanceJson(v.referenceToMesh, v.voxel)},
        {"closed", t.closed()},
        {"manifold", t.manifold()},
        {"oriented", t.oriented()},
        {"outward", t.outward()},
        {"euler", t.euler},
        {"components", t.components},
        {"boundary_edges", t.boundaryEdges},
        {"non_manifold_edges", t.nonManifoldEdges},
        {"non_manifold_vertices", t.nonManifoldVertices},
        {"misoriented_edges", t.misorientedEdges},
        {"area", v.quality.area},
        {"reference_area", v.referenceArea},
        {"volume", t.signedVolume},
        {"reference_volume", v.referenceVolume},
        {"smallest_angle", v.quality.smallestAngle},
        {"largest_aspect", v.quality.largestAspect},
        {"degenerate_triangles", v.quality.degenerate},
        {"triangles_below_5_degrees", v.quality.needles},
        {"reference_triangles", v.referenceTriangles},
        {"reference_seconds", v.referenceSeconds},
        {"seconds", v.seconds},
    };
    if (v.hasLevelSet) j["level_set"] = distanceJson(v.levelSet, v.voxel);
    return j;
}

std::string reportText(const nlohmann::json& report, int indent)
{
    return report.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

} // namespace pipetile::tools
