// pipetile — one volume meshed into its level files and report, as one transaction.

#include "frame.h"

#include "html_report.h"
#include "report.h"

#include <pipetile/error.h>
#include <pipetile/mesh_io.h>
#include <pipetile/quality.h>

#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace pipetile::tools {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

__attribute__((format(printf, 1, 2))) std::string format(const char* pattern, ...)
{
    va_list args, again;
    va_start(args, pattern);
    va_copy(again, args);
    const int size = std::vsnprintf(nullptr, 0, pattern, args);
    va_end(args);
    std::string text(static_cast<std::size_t>(std::max(size, 0)) + 1, '\0');
    std::vsnprintf(text.data(), text.size(), pattern, again);
    va_end(again);
    text.resize(text.size() - 1);
    return text;
}

// Whether two paths name one file: by device and inode where both exist (hard links, symbolic
// links and other spellings of one file), else by their normalised absolute paths.
bool sameFile(const std::string& a, const std::string& b)
{
    std::error_code ec;
    if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
    // Where either path cannot be made canonical (out of memory, say: both come back empty, and
    // under an address-space limit every output was taken for the input, an exit 2 where the run
    // should end in "out of memory"), the paths as written decide.
    std::error_code ecA, ecB;
    const std::filesystem::path canonicalA = std::filesystem::weakly_canonical(a, ecA),
                                canonicalB = std::filesystem::weakly_canonical(b, ecB);
    if (ecA || ecB) return std::filesystem::path(a).lexically_normal() == std::filesystem::path(b).lexically_normal();
    return canonicalA == canonicalB;
}

// Binary STL holds float32 only: far from the origin that moves vertices. Say so beyond 1/100 voxel.
void warnIfRounded(const std::string& output, double rounding, double voxel, const Notify& notify)
{
    if (rounding > 0.01 * voxel)
        notify("warning",
               format("'%s': float32 coordinates (the format's only kind) move vertices by up to %.3g voxels "
                      "this far from the origin; write .ply, .obj or .off to keep them exact",
                      output.c_str(), rounding / voxel));
}

// Level 0, then each level refined from the one before (only the new rays are cast).
std::vector<LevelMesh> buildLevels(const Reconstruction& reconstruction, const FrameJob& job)
{
    Refinement refinement(reconstruction);
    std::vector<LevelMesh> levels{refinement.mesh()};
    const int count = reconstruction.levelCount();
    if (job.levelDone) job.levelDone(1, count);
    while (refinement.canRefine()) {
        levels.push_back(refinement.refine());
        if (job.levelDone) job.levelDone(static_cast<int>(levels.size()), count);
    }
    return levels;
}

} // namespace

void checkWritableTarget(const std::string& path, const char* what)
{
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
        throw Error("'" + path + "': the folder '" + folder.string() + "' for the " + what +
                    " does not exist; create it first");
}

std::string levelPath(const std::string& output, int level)
{
    const std::filesystem::path p(output);
    std::filesystem::path name = p.parent_path() / (p.stem().string() + "_L" + std::to_string(level));
    name += p.extension();
    return name.string();
}

std::vector<std::string> staleLevels(const std::string& output, int levels)
{
    std::vector<std::string> stale;
    if (isGlbPath(output)) return stale;
    const std::filesystem::path p(output);
    const std::string prefix = p.stem().string() + "_L", extension = p.extension().string();
    std::error_code ec;
    const std::filesystem::path folder = p.parent_path().empty() ? std::filesystem::path(".") : p.parent_path();
    for (std::filesystem::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.size() <= prefix.size() + extension.size() || name.compare(0, prefix.size(), prefix) != 0 ||
            name.compare(name.size() - extension.size(), extension.size(), extension) != 0)
            continue;
        const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - extension.size());
        if (digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
        const int level = std::stoi(digits);
        std::error_code typeError;
        if (level >= levels && levelPath(output, level) == (p.parent_path() / name).string() &&
            it->is_regular_file(typeError))
            stale.push_back(levelPath(output, level));
    }
    std::sort(stale.begin(), stale.end());
    return stale;
}

bool outputsExist(const std::string& output, const std::string& report, int levels)
{
    std::error_code ec;
    if (isGlbPath(output)) levels = 0;
    if (isGlbPath(output) && !std::filesystem::exists(output, ec)) return false;
    for (int level = 0; level < levels; ++level)
        if (!std::filesystem::exists(levelPath(output, level), ec)) return false;
    return report.empty() || std::filesystem::exists(report, ec);
}

void refuseClobbering(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs)
{
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        for (const NamedPath& in : inputs)
            if (!in.path.empty() && sameFile(outputs[o].path, in.path))
                throw UsageError("the " + outputs[o].what + " '" + outputs[o].path + "' is the " + in.what + " '" +
                                 in.path + "': writing it would destroy it; choose another name");
        for (std::size_t p = 0; p < o; ++p)
            if (sameFile(outputs[o].path, outputs[p].path))
                throw UsageError("the " + outputs[o].what + " '" + outputs[o].path + "' is also the " +
                                 outputs[p].what + "; give them different names");
    }
}

std::unique_ptr<OutputSet> openOutputs(const std::vector<NamedPath>& outputs, const std::string& owner,
                                       const Notify& notify, const std::vector<std::string>& obsolete)
{
    std::vector<std::string> paths;
    for (const NamedPath& o : outputs) paths.push_back(o.path);
    auto set = std::make_unique<OutputSet>(paths, owner, obsolete);
    const std::vector<std::string>& recovered = set->recovered();
    if (!recovered.empty())
        notify("note", format("finished the commit of a pipetile run that was killed while it replaced its outputs "
                              "(%zu file%s: %s%s), so they are all of that run",
                              recovered.size(), recovered.size() == 1 ? "" : "s", recovered.front().c_str(),
                              recovered.size() == 1 ? "" : ", ..."));
    const std::vector<std::string>& stale = set->staleRemoved();
    if (!stale.empty())
        notify("note",
               format("removed %zu temporary file%s left by a pipetile run that was killed (%s%s)", stale.size(),
                      stale.size() == 1 ? "" : "s", stale.front().c_str(), stale.size() == 1 ? "" : ", ..."));
    return set;
}

void noteIsovalue(const Volume& volume, const Notify& notify)
{
    const std::string grid = "grid '" + pipetile::printableName(volume.gridName()) + "'";
    if (volume.hotVoxels() > 0) {
        const bool one = volume.hotVoxels() == 1;
        notify("note", format("%s: iso %g, halfway from the background %g to %g; %lld voxel%s denser (up to %g), too "
                              "few to be the object (fewer than %lld), so the default ignores %s; pass --iso to choose",
                              grid.c_str(), volume.iso(), volume.background(), 2.0 * volume.iso() - volume.background(),
                              volume.hotVoxels(), one ? " is" : "s are", volume.maxValue(), kFewestObjectVoxels,
                              one ? "it" : "them"));
    }
    if (volume.insideVoxels() < kFewestObjectVoxels)
        notify("warning",
               format("%s: only %lld active voxel%s inside the surface at iso %g: the mesh can only be specks "
                      "(values range from %g to %g; choose --iso)",
                      grid.c_str(), volume.insideVoxels(), volume.insideVoxels() == 1 ? " lies" : "s lie", volume.iso(),
                      volume.minValue(), volume.maxValue()));
}

namespace {

// Pieces no construction handles are capped one by one, so the mesh's topology can differ from
// the isosurface's there: a user comparing the two should not have to find that in the report.
void warnIfUnresolved(const Volume& volume, const ReconstructionStats& stats, const Notify& notify)
{
    const int pieces = stats.unresolvedEvents + stats.unresolvedJunctions;
    if (pieces == 0) return;
    notify("warning", format("grid '%s': %d slab piece%s (%d of them forks or merges) fit no construction and %s "
                             "capped contour by contour: there the mesh's topology can differ from the "
                             "isosurface's (see the report's events; --validate compares them)",
                             pipetile::printableName(volume.gridName()).c_str(), pieces, pieces == 1 ? "" : "s",
                             stats.unresolvedJunctions, pieces == 1 ? "is" : "are"));
}

// The slabs' labelling counts no handle that lies within one slab (voxels joined around a corner
// of a cell, say), so the isosurface can have handles the mesh lacks though every piece fits a
// construction: the cells' own count says so, and where (the report's euler_differences), and the
// user is told rather than left to find it.
void warnIfHandlesMissed(const Volume& volume, const json& report, const Notify& notify)
{
    const json& events = report["events"];
    const long long slabs = events["euler"].get<long long>(), cells = events["isosurface_euler"].get<long long>();
    if (slabs == cells) return;
    const long long handles = (std::llabs(slabs - cells) + 1) / 2; // a handle changes the Euler characteristic by 2
    // The slabs where the difference arises; a change that the next one undoes is one critical
    // point that the two count on either side of a plane, not a handle.
    const json& changes = events["euler_differences"];
    const std::string axis = report["axis"].get<std::string>();
    std::string where;
    int listed = 0, more = 0;
    for (std::size_t k = 0; k < changes.size(); ++k) {
        const long long d = changes[k]["difference"].get<long long>();
        const bool undone = (k + 1 < changes.size() && changes[k + 1]["difference"].get<long long>() == -d) ||
                            (k > 0 && changes[k - 1]["difference"].get<long long>() == -d);
        if (undone) continue;
        if (listed == 4) {
            ++more;
            continue;
        }
        const auto plane = [](const json& w) {
            return w.is_null() ? std::string("the end") : format("%g", w.get<double>());
        };
        where += format("%s%s %s and %s (by %+lld)", listed ? ", " : "", axis.c_str(),
                        plane(changes[k]["w_below"]).c_str(), plane(changes[k]["w_above"]).c_str(), d);
        ++listed;
    }
    if (more) where += format(" and %d more", more);
    notify("warning",
           format("grid '%s': the isosurface's Euler characteristic is %lld (counted from its cells as volumeToMesh "
                  "sees them) but the slabs' is %lld: the mesh %s %lld handle%s at the voxel scale %s%s%s (--validate "
                  "compares the topologies)",
                  pipetile::printableName(volume.gridName()).c_str(), cells, slabs, slabs > cells ? "lacks" : "has",
                  handles, handles == 1 ? "" : "s",
                  slabs > cells ? "that no slab piece shows" : "that the isosurface lacks",
                  listed ? "; the two counts part between index " : "", where.c_str()));
}

// The constructions' own sum (caps less saddles, and the patches') is the mesh's Euler
// characteristic; where it differs from the slab pieces' sum though every piece was resolved, some
// piece was closed otherwise than it counts (contours capped one by one where the slab joins them
// past the box, and the patch found a handle the labelling lacks), and the user is told.
void warnIfBuiltDiffers(const Volume& volume, const ReconstructionStats& stats, const json& report,
                        const Notify& notify)
{
    const json& events = report["events"];
    const long long slabs = events["euler"].get<long long>(), built = events["built_euler"].get<long long>();
    if (slabs == built || stats.unresolvedEvents + stats.unresolvedJunctions > 0) return; // warned of already
    notify("warning",
           format("grid '%s': the mesh's Euler characteristic is %lld where its slab pieces count %lld: some "
                  "piece was closed contour by contour where the slab joins its contours (see the "
                  "report's events and graph; --validate compares the topologies)",
                  pipetile::printableName(volume.gridName()).c_str(), built, slabs));
}

} // namespace

json meshFrame(const FrameJob& job)
{
    const Clock::time_point start = Clock::now();
    checkMeshOptions(job.options);

    // Fail before any work on outputs that could never be written.
    const bool glb = isGlbPath(job.output);
    if (!glb && !isMeshExtension(job.output))
        throw UsageError("-o '" + job.output + "': unknown mesh format; use .ply .obj .stl .off .glb");
    if (job.metresPerUnit != 1.0 && !glb)
        throw UsageError("--units scales a .glb (glTF is in metres); '" + job.output +
                         "' keeps the grid's world units as they are");
    checkWritableTarget(job.output, "meshes");
    if (!job.report.empty()) checkWritableTarget(job.report, "report");
    if (!job.html.empty()) {
        checkHtmlReportAvailable(job.html);
        checkWritableTarget(job.html, "HTML report");
    }
    std::vector<NamedPath> outputs;
    if (glb) outputs.push_back({job.output, "levels (.glb)"});
    for (int level = 0; level < job.options.levels && !glb; ++level)
        outputs.push_back({levelPath(job.output, level), "mesh of level " + std::to_string(level)});
    if (!job.report.empty()) outputs.push_back({job.report, "report"});
    if (!job.html.empty()) outputs.push_back({job.html, "HTML report"});
    refuseClobbering({{job.input, "input volume"}}, outputs);
    // Levels of an earlier run with more levels go with this commit, so the set is this run's
    // alone; never the input, whatever its name.
    std::vector<std::string> obsolete;
    for (const std::string& stale : staleLevels(job.output, job.options.levels))
        if (job.input.empty() || !sameFile(stale, job.input)) obsolete.push_back(stale);
    std::unique_ptr<OutputSet> files = openOutputs(outputs, job.owner, job.notify, obsolete);

    const Volume volume = job.read ? job.read() : readVolume(job.input, job.volume);
    noteIsovalue(volume, job.notify);
    const Reconstruction reconstruction(volume, job.options);
    if (reconstruction.finestUsefulLevel() < reconstruction.levelCount() - 1)
        job.notify("warning", format("levels above %d cast more rays than the longest boundary has pixels (%lld); they "
                                     "add vertices but no detail (lower --levels or --rays)",
                                     reconstruction.finestUsefulLevel(), reconstruction.stats().longestBoundary));
    warnIfUnresolved(volume, reconstruction.stats(), job.notify);
    const std::vector<LevelMesh> levels = buildLevels(reconstruction, job);

    // Each level to its temporary file; they replace the earlier files together, with the report.
    // A .glb holds every level over one vertex array (written below, with the validation's errors).
    const auto levelFile = [&](int level) { return glb ? job.output : levelPath(job.output, level); };
    double rounding = 0.0;
    for (const LevelMesh& level : levels) {
        if (glb) continue;
        MeshWriteOptions write;
        write.normals = vertexNormals(volume, level.mesh); // the field's gradient, outward
        rounding = std::max(rounding, writeMesh(level.mesh, *files, levelFile(level.level), write));
    }
    warnIfRounded(job.output, rounding, volume.smallestVoxel(), job.notify);
    const bool nest = glb || !job.html.empty();
    const NestedLevels nested = nest ? nestLevels(levels) : NestedLevels{};

    json report = meshReport(volume, reconstruction);
    warnIfHandlesMissed(volume, report, job.notify);
    warnIfBuiltDiffers(volume, reconstruction.stats(), report, job.notify);
    for (const LevelMesh& level : levels) {
        // The level's own topology is a linear pass over its triangles: only when a report is asked for.
        report["levels"].push_back(levelReport(level, !job.report.empty() || !job.html.empty()));
        report["levels"].back()["file"] = levelFile(level.level);
    }
    report["seconds"] = std::chrono::duration<double>(Clock::now() - start).count();
    GlbOptions glbOptions;
    glbOptions.metresPerUnit = job.metresPerUnit;
    if (nest) glbOptions.normals = vertexNormals(volume, nestedMesh(nested, nested.vertexCounts.size() - 1));
    if (job.beforeCommit) job.beforeCommit(volume, reconstruction, levels, nested, report, glbOptions);
    if (glb) writeGlb(nested, *files, job.output, glbOptions);
    if (!job.html.empty()) {
        const ReconstructionStats& stats = reconstruction.stats();
        HtmlReport html;
        html.title = "pipetile mesh: " + volume.source();
        html.subtitle = format("grid '%s' (%s, iso %g), axis %s, %d slices, %d tubes",
                               pipetile::printableName(volume.gridName()).c_str(), toString(volume.volumeClass()),
                               volume.iso(), axisName(reconstruction.plan().axis), stats.slices, stats.tubes);
        html.levels = report["levels"];
        html.voxel = volume.smallestVoxel();
        writeHtmlReport(*files, job.html, html, nested, glbOptions);
    }
    if (!job.report.empty()) files->write(job.report, [&](std::ostream& out) { out << reportText(report, 2) << '\n'; });
    files->commit();
    files.reset(); // releases and removes the lock files: nothing of this run is left to do
    if (job.committed) job.committed();
    return report;
}

} // namespace pipetile::tools
