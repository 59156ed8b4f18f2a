// pipetile — the command line: parse, call the library, print, map exceptions to exit codes.
// Exit codes: 0 ok, 1 a failure (the message names the file or grid and what to do), 2 usage.

#include <pipetile/pipetile.h>

#include "bench.h"
#include "report.h"
#include "phantoms.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

void writeJson(const json& report, pipetile::OutputSet& outputs, const std::string& path)
{
    outputs.write(path, [&](std::ostream& out) { out << report.dump(2) << '\n'; });
}

// name_L<k>.ext next to the path the user gave.
std::string levelPath(const std::string& output, int level)
{
    const std::filesystem::path p(output);
    std::filesystem::path name = p.parent_path() / (p.stem().string() + "_L" + std::to_string(level));
    name += p.extension();
    return name.string();
}

// What is wrong with a mesh's topology, in words, with where the first non-manifold edge and
// vertex are (coordinates, since every format numbers vertices its own way); empty if nothing is.
std::string topologyProblems(const pipetile::TriangleMesh& mesh, const pipetile::Topology& t)
{
    auto at = [&](long long v) {
        const glm::dvec3& p = mesh.vertices[static_cast<std::size_t>(v)];
        char buffer[96];
        std::snprintf(buffer, sizeof buffer, "(%g, %g, %g)", p.x, p.y, p.z);
        return std::string(buffer);
    };
    auto count = [](long long n, const char* what) {
        return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
    };
    std::vector<std::string> parts;
    if (t.nonManifoldEdges > 0)
        parts.push_back(count(t.nonManifoldEdges, "non-manifold edge") + " (in 3 or more triangles; one joins " +
                        at(t.firstNonManifoldEdge[0]) + " and " + at(t.firstNonManifoldEdge[1]) + ")");
    if (t.nonManifoldVertices > 0)
        parts.push_back(count(t.nonManifoldVertices, "non-manifold vertex") + " (where separate fans of triangles meet; one at " +
                        at(t.firstNonManifoldVertex) + ")");
    if (t.boundaryEdges > 0) parts.push_back(count(t.boundaryEdges, "boundary edge"));
    if (t.misorientedEdges > 0) parts.push_back(count(t.misorientedEdges, "misoriented edge"));
    std::string text;
    for (const std::string& part : parts) text += (text.empty() ? "" : ", ") + part;
    return text;
}

void printValidationHeader()
{
    std::printf("%-8s %10s %8s %8s %8s  %-6s %-8s %-8s %-7s %5s %9s\n", "", "hausdorff", "mean", "rms", "|phi|max",
                "closed", "manifold", "oriented", "outward", "euler", "min angle");
}

void printValidationRow(const std::string& label, const pipetile::Validation& v)
{
    const pipetile::Topology& t = v.topology;
    const std::string phi = v.hasLevelSet ? std::to_string(v.levelSet.max / v.voxel).substr(0, 6) : "-";
    std::printf("%-8s %10.3f %8.3f %8.3f %8s  %-6s %-8s %-8s %-7s %5lld %8.1f°   (voxels of %g)\n", label.c_str(),
                v.symmetric.max / v.voxel, v.symmetric.mean / v.voxel, v.symmetric.rms / v.voxel, phi.c_str(),
                t.closed() ? "yes" : "NO", t.manifold() ? "yes" : "NO", t.oriented() ? "yes" : "NO",
                t.outward() ? "yes" : "NO", t.euler, v.quality.smallestAngle, v.voxel);
}

void checkWritableTarget(const std::string& path, const char* what)
{
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
        throw pipetile::Error("'" + path + "': the folder '" + folder.string() + "' for the " + what +
                              " does not exist; create it first");
}

// Whether two paths name one file: by device and inode where both exist (hard links, symbolic
// links and other spellings of one file), else by their normalised absolute paths.
bool sameFile(const std::string& a, const std::string& b)
{
    std::error_code ec;
    if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
    return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

struct NamedPath {
    std::string path;
    std::string what; // "input volume", "report", ...
};

// Refuses, before any work, an output that is one of the inputs or another output: it would be
// overwritten (a report over the volume it describes, a coloured mesh over the mesh it reads).
void refuseClobbering(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs)
{
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        for (const NamedPath& in : inputs)
            if (!in.path.empty() && sameFile(outputs[o].path, in.path))
                throw pipetile::UsageError("the " + outputs[o].what + " '" + outputs[o].path + "' is the " + in.what +
                                           " '" + in.path + "': writing it would destroy it; choose another name");
        for (std::size_t p = 0; p < o; ++p)
            if (sameFile(outputs[o].path, outputs[p].path))
                throw pipetile::UsageError("the " + outputs[o].what + " '" + outputs[o].path + "' is also the " +
                                           outputs[p].what + "; give them different names");
    }
}

// The run's outputs as one transaction, locked before any work: a concurrent run writing any of
// them fails now, and is told this one's command line.
std::unique_ptr<pipetile::OutputSet> openOutputs(const std::vector<NamedPath>& outputs, const std::string& owner)
{
    std::vector<std::string> paths;
    for (const NamedPath& o : outputs) paths.push_back(o.path);
    auto set = std::make_unique<pipetile::OutputSet>(paths, owner);
    const std::vector<std::string>& stale = set->staleRemoved();
    if (!stale.empty())
        std::fprintf(stderr, "pipetile: note: removed %zu temporary file%s left by a pipetile run that was killed (%s%s)\n",
                     stale.size(), stale.size() == 1 ? "" : "s", stale.front().c_str(), stale.size() == 1 ? "" : ", ...");
    return set;
}

// Binary STL holds float32 only: far from the origin that moves vertices. Say so beyond 1/100 voxel.
void warnIfRounded(const std::string& output, double rounding, double voxel)
{
    if (rounding > 0.01 * voxel)
        std::fprintf(stderr, "pipetile: warning: '%s': float32 coordinates (the format's only kind) move vertices by up "
                             "to %.3g voxels this far from the origin; write .ply, .obj or .off to keep them exact\n",
                     output.c_str(), rounding / voxel);
}

// Says on stderr when the isovalue deserves a second look: the default fog isovalue left hot
// voxels out, or so few voxels lie inside that the mesh can only be specks.
void noteIsovalue(const pipetile::Volume& volume)
{
    const std::string grid = "grid '" + volume.gridName() + "'";
    if (volume.hotVoxels() > 0) {
        const bool one = volume.hotVoxels() == 1;
        std::fprintf(stderr, "pipetile: note: %s: iso %g, halfway from the background %g to %g; %lld voxel%s denser (up "
                             "to %g), too few to be the object (fewer than %lld), so the default ignores %s; pass --iso "
                             "to choose\n",
                     grid.c_str(), volume.iso(), volume.background(), 2.0 * volume.iso() - volume.background(),
                     volume.hotVoxels(), one ? " is" : "s are", volume.maxValue(), pipetile::kFewestObjectVoxels,
                     one ? "it" : "them");
    }
    if (volume.insideVoxels() < pipetile::kFewestObjectVoxels)
        std::fprintf(stderr, "pipetile: warning: %s: only %lld active voxel%s inside the surface at iso %g: the mesh "
                             "can only be specks (values range from %g to %g; choose --iso)\n",
                     grid.c_str(), volume.insideVoxels(), volume.insideVoxels() == 1 ? " lies" : "s lie", volume.iso(),
                     volume.minValue(), volume.maxValue());
}

struct MeshArgs {
    std::string input, output, grid, report;
    std::optional<double> iso;
    std::string axis = "auto";
    double spacing = 2.0;
    int rays = 8, levels = 4, threads = 0;
    bool validate = false, everySlice = false;
    std::string tiler = "contour-tree";
    std::string owner; // the command line, for a concurrent run's message
};

int runMesh(const MeshArgs& args)
{
    const Clock::time_point start = Clock::now();
    pipetile::MeshOptions options;
    options.slicing.spacingVoxels = args.spacing;
    options.slicing.axis = args.axis == "x" ? pipetile::Axis::X : args.axis == "y" ? pipetile::Axis::Y
                         : args.axis == "z" ? pipetile::Axis::Z : pipetile::Axis::Auto;
    options.baseRays = args.rays;
    options.levels = args.levels;
    options.threads = args.threads;
    options.everySlice = args.everySlice;
    options.tiler = args.tiler == "optimal" ? pipetile::TilerKind::Optimal
                  : args.tiler == "greedy"  ? pipetile::TilerKind::Greedy : pipetile::TilerKind::ContourTree;
    pipetile::checkMeshOptions(options);

    // Fail before any work on outputs that could never be written.
    const std::string output = !args.output.empty() ? args.output
        : (args.input.empty() ? std::string("phantom") : std::filesystem::path(args.input).stem().string()) + ".ply";
    if (!pipetile::isMeshExtension(output))
        throw pipetile::UsageError("-o '" + output + "': unknown mesh format; use .ply .obj .stl .off");
    checkWritableTarget(output, "meshes");
    if (!args.report.empty()) checkWritableTarget(args.report, "report");
    std::vector<NamedPath> outputs;
    for (int level = 0; level < args.levels; ++level)
        outputs.push_back({levelPath(output, level), "mesh of level " + std::to_string(level)});
    if (!args.report.empty()) outputs.push_back({args.report, "report"});
    refuseClobbering({{args.input, "input volume"}}, outputs);
    const std::unique_ptr<pipetile::OutputSet> files = openOutputs(outputs, args.owner);

    pipetile::VolumeOptions volumeOptions;
    volumeOptions.gridName = args.grid;
    volumeOptions.iso = args.iso;
    const pipetile::Volume volume = args.input.empty() ? pipetile::samples::makeSample("phantom")
                                                       : pipetile::readVolume(args.input, volumeOptions);
    if (args.input.empty() && args.iso) throw pipetile::UsageError("--iso needs an INPUT file");
    noteIsovalue(volume);

    // Level 0, then each level refined from the one before (only the new rays are cast).
    const pipetile::Reconstruction reconstruction(volume, options);
    if (reconstruction.finestUsefulLevel() < reconstruction.levelCount() - 1)
        std::fprintf(stderr, "pipetile: warning: levels above %d cast more rays than the longest boundary has pixels (%lld); "
                             "they add vertices but no detail (lower --levels or --rays)\n",
                     reconstruction.finestUsefulLevel(), reconstruction.stats().longestBoundary);
    pipetile::Refinement refinement(reconstruction);
    std::vector<pipetile::LevelMesh> levels{refinement.mesh()};
    while (refinement.canRefine()) levels.push_back(refinement.refine());

    // Each level to its temporary file; they replace the earlier files together, with the report.
    double rounding = 0.0;
    for (const pipetile::LevelMesh& level : levels) {
        pipetile::MeshWriteOptions write;
        write.normals = pipetile::vertexNormals(volume, level.mesh);
        rounding = std::max(rounding, pipetile::writeMesh(level.mesh, *files, levelPath(output, level.level), write));
    }
    warnIfRounded(output, rounding, volume.smallestVoxel());

    const pipetile::ReconstructionStats& stats = reconstruction.stats();
    json report = pipetile::tools::meshReport(volume, reconstruction);
    std::printf("%s  grid '%s' (%s, iso %g), axis %s, %d slices, %d contours in %d tubes\n", volume.source().c_str(),
                volume.gridName().c_str(), pipetile::toString(volume.volumeClass()), volume.iso(),
                pipetile::tools::axisName(reconstruction.plan().axis), stats.slices, stats.contours, stats.tubes);
    std::printf("%5s %6s %10s %10s %9s  %s\n", "level", "rays", "vertices", "triangles", "seconds", "file");
    for (std::size_t k = 0; k < levels.size(); ++k) {
        const pipetile::LevelMesh& level = levels[k];
        // The level's own topology is a linear pass over its triangles: only when a report is asked for.
        report["levels"].push_back(pipetile::tools::levelReport(level, !args.report.empty()));
        report["levels"][k]["file"] = levelPath(output, level.level);
        std::printf("%5d %6d %10zu %10zu %9.4f  %s\n", level.level, level.rays, level.mesh.vertices.size(),
                    level.mesh.triangles.size(), level.seconds, levelPath(output, level.level).c_str());
    }
    report["seconds"] = secondsSince(start);
    if (args.validate) {
        // One reference isosurface for all levels; its time is the same-run peer of ours.
        const pipetile::Validator validator(volume, {1.0, args.threads});
        std::printf("\nvalidation against volumeToMesh (%zu triangles, %.4f s):\n", validator.reference().triangles.size(),
                    validator.referenceSeconds());
        printValidationHeader();
        for (std::size_t k = 0; k < levels.size(); ++k) {
            const pipetile::Validation v = validator.validate(levels[k].mesh);
            report["levels"][k]["validation"] = pipetile::tools::validationReport(v);
            printValidationRow("L" + std::to_string(levels[k].level), v);
        }
    }
    if (!args.report.empty()) writeJson(report, *files, args.report);
    files->commit();
    return 0;
}

struct ValidateArgs {
    std::string input, mesh, grid, report, colors, owner;
    std::optional<double> iso;
    int threads = 0;
};

int runValidate(const ValidateArgs& args)
{
    if (!args.report.empty()) checkWritableTarget(args.report, "report");
    if (!args.colors.empty()) {
        if (std::filesystem::path(args.colors).extension() != ".ply")
            throw pipetile::UsageError("--error-colors '" + args.colors + "': the coloured mesh is written as .ply");
        checkWritableTarget(args.colors, "coloured mesh");
    }
    std::vector<NamedPath> outputs;
    if (!args.colors.empty()) outputs.push_back({args.colors, "coloured mesh"});
    if (!args.report.empty()) outputs.push_back({args.report, "report"});
    refuseClobbering({{args.input, "input volume"}, {args.mesh, "mesh to validate"}}, outputs);
    const std::unique_ptr<pipetile::OutputSet> files = openOutputs(outputs, args.owner);
    pipetile::VolumeOptions volumeOptions;
    volumeOptions.gridName = args.grid;
    volumeOptions.iso = args.iso;
    const pipetile::Volume volume = pipetile::readVolume(args.input, volumeOptions);
    noteIsovalue(volume);
    const pipetile::TriangleMesh mesh = pipetile::readMesh(args.mesh);
    if (mesh.triangles.empty())
        throw pipetile::Error("'" + args.mesh + "': the mesh has " + std::to_string(mesh.vertices.size()) +
                              " vertices and no faces; nothing to validate");
    const pipetile::Validator validator(volume, {1.0, args.threads});
    const pipetile::Validation v = validator.validate(mesh);
    std::printf("%s against the isosurface of %s, grid '%s' at iso %g (volumeToMesh: %zu triangles, %.4f s)\n",
                args.mesh.c_str(), args.input.c_str(), volume.gridName().c_str(), volume.iso(),
                validator.reference().triangles.size(), validator.referenceSeconds());
    printValidationHeader();
    printValidationRow("mesh", v);
    const std::string problems = topologyProblems(mesh, v.topology);
    if (!problems.empty()) std::printf("topology: %s\n", problems.c_str());
    if (!args.colors.empty()) {
        pipetile::MeshWriteOptions options;
        options.colors = pipetile::errorColors(v.vertexDistance, v.voxel);
        options.quality = v.vertexDistance;
        options.normals = pipetile::vertexNormals(volume, mesh);
        pipetile::writeMesh(mesh, *files, args.colors, options);
    }
    if (!args.report.empty()) {
        json report = {{"input", args.input}, {"grid", volume.gridName()}, {"iso", volume.iso()}, {"mesh", args.mesh},
                       {"vertices", mesh.vertices.size()}, {"triangles", mesh.triangles.size()},
                       {"validation", pipetile::tools::validationReport(v)}};
        writeJson(report, *files, args.report);
    }
    files->commit();
    if (!args.colors.empty()) std::printf("wrote %s: blue on the isosurface, red at 1 voxel or more\n", args.colors.c_str());
    return 0;
}

int runSample(const std::string& name, const std::string& output, bool list)
{
    if (list || name.empty()) {
        for (const pipetile::samples::SampleInfo& s : pipetile::samples::sampleList())
            std::printf("%-14s %4d x %4d x %4d  %s\n", s.name.c_str(), s.dims.x, s.dims.y, s.dims.z, s.description.c_str());
        return 0;
    }
    if (output.empty()) throw pipetile::UsageError("sample: give the output file with -o FILE.vdb");
    if (std::filesystem::path(output).extension() != ".vdb")
        throw pipetile::UsageError("-o '" + output + "': samples are written as .vdb files");
    checkWritableTarget(output, "sample");
    pipetile::writeVolume(pipetile::samples::makeSample(name), output);
    std::printf("wrote %s (%s)\n", output.c_str(), name.c_str());
    return 0;
}

int runInfo(const std::string& input)
{
    for (const pipetile::GridSummary& g : pipetile::listGrids(input)) {
        std::printf("grid '%s': %s, %s, %lld active voxels, bbox [%d %d %d] -> [%d %d %d], voxel %g x %g x %g\n",
                    g.name.c_str(), g.valueType.c_str(), g.gridClass.c_str(), g.activeVoxels, g.bboxMin.x, g.bboxMin.y,
                    g.bboxMin.z, g.bboxMax.x, g.bboxMax.y, g.bboxMax.z, g.voxelSize.x, g.voxelSize.y, g.voxelSize.z);
    }
    return 0;
}

// SIGINT, SIGTERM and SIGHUP go to one thread that waits for them (blocked everywhere else, worker
// threads included): it abandons the outputs, which removes this run's temporaries and waits for a
// commit in progress, so the earlier outputs stay whole, then ends the process by the same signal.
void handleSignalsInOneThread()
{
    static sigset_t signals;
    sigemptyset(&signals);
    for (const int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&signals, s);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    std::thread([] {
        int s = 0;
        if (sigwait(&signals, &s) != 0) return;
        pipetile::abandonOutputs();
        std::fprintf(stderr, "pipetile: stopped by %s; this run's files are removed, earlier outputs are as they were\n",
                     strsignal(s));
        std::signal(s, SIG_DFL);
        sigset_t one;
        sigemptyset(&one);
        sigaddset(&one, s);
        pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
        std::raise(s);
    }).detach();
}

std::string commandLine(int argc, char** argv)
{
    std::string line = "pipetile";
    for (int i = 1; i < argc; ++i) line += std::string(" ") + argv[i];
    return line;
}

std::string formatNumber(double v)
{
    std::ostringstream os;
    os << v;
    return os.str();
}

// What to tell a user whose run ran out of memory (std::bad_alloc, or a container asked for more
// than it can hold): which run, and what makes it smaller.
std::string outOfMemory(const MeshArgs* mesh, const ValidateArgs* validate)
{
    if (mesh) {
        const std::string input = mesh->input.empty() ? std::string("the phantom") : "'" + mesh->input + "'";
        return "out of memory meshing " + input + " with --levels " + std::to_string(mesh->levels) + ", --rays " +
               std::to_string(mesh->rays) + ", --spacing " + formatNumber(mesh->spacing) +
               ": lower --levels or --rays, raise --spacing, or clip the grid to the object";
    }
    if (validate)
        return "out of memory validating '" + validate->mesh + "' against '" + validate->input +
               "': the isosurface of the whole grid and the mesh must fit; clip the grid to the object or "
               "validate a coarser level";
    return "out of memory: use a smaller grid (clip it to the object) or fewer levels";
}

} // namespace

int main(int argc, char** argv)
{
    handleSignalsInOneThread();
    CLI::App app{"pipetile: multiresolution triangle meshes of pipe-shaped objects from OpenVDB volumes"};
    app.require_subcommand(1);

    MeshArgs meshArgs;
    CLI::App* mesh = app.add_subcommand("mesh", "Mesh a .vdb volume (default: the bundled phantom) at several levels");
    mesh->add_option("INPUT", meshArgs.input, "input .vdb file; omitted: the bundled 'phantom' sample");
    mesh->add_option("-o,--output", meshArgs.output, "output mesh; level k goes to NAME_L<k>.EXT (.ply .obj .stl .off)");
    mesh->add_option("--grid", meshArgs.grid, "grid name (default: the first float grid)");
    mesh->add_option("--iso", meshArgs.iso, "isovalue (default: 0 for level sets; fog: halfway from background to max)");
    mesh->add_option("--axis", meshArgs.axis, "slicing axis")->check(CLI::IsMember({"x", "y", "z", "auto"}));
    mesh->add_option("--spacing", meshArgs.spacing, "slice spacing in voxels")->check(CLI::Range(0.1, 1000.0));
    mesh->add_option("--rays", meshArgs.rays, "rays at level 0 (n0)")->check(CLI::Range(3, 4096));
    mesh->add_option("--levels", meshArgs.levels, "levels of detail")->check(CLI::Range(1, 16));
    mesh->add_option("--report", meshArgs.report, "write a JSON report");
    mesh->add_option("--threads", meshArgs.threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));
    mesh->add_flag("--validate", meshArgs.validate, "compare every level with volumeToMesh's isosurface");
    mesh->add_option("--tiler", meshArgs.tiler, "tiler: the paper's contour trees, or a toroidal baseline")
        ->check(CLI::IsMember({"contour-tree", "optimal", "greedy"}));
    mesh->add_flag("--every-slice", meshArgs.everySlice,
                   "tile every slice at every level, as the paper does (default: coarse levels skip the slices "
                   "their neighbours predict within the level's own error)");

    pipetile::tools::BenchArgs benchArgs;
    CLI::App* bench = app.add_subcommand("bench", "Time pipetile against its baselines and volumeToMesh on one grid");
    bench->add_option("INPUT", benchArgs.input, "input .vdb file; omitted: the bundled 'phantom' sample");
    bench->add_option("--report", benchArgs.report, "write the figures as JSON");
    bench->add_option("--repeat", benchArgs.repeat, "repetitions per figure (median reported)")->check(CLI::Range(1, 1000));
    bench->add_option("--threads", benchArgs.threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));

    ValidateArgs validateArgs;
    CLI::App* validate = app.add_subcommand("validate", "Compare any mesh with the isosurface of a .vdb volume");
    validate->add_option("INPUT", validateArgs.input, "input .vdb file")->required();
    validate->add_option("MESH", validateArgs.mesh, "mesh file (.ply .obj .stl .off), from pipetile or any tool")->required();
    validate->add_option("--grid", validateArgs.grid, "grid name (default: the first float grid)");
    validate->add_option("--iso", validateArgs.iso, "isovalue (default as for mesh)");
    validate->add_option("--report", validateArgs.report, "write a JSON report");
    validate->add_option("--error-colors", validateArgs.colors, "write the mesh as .ply coloured by its distance");
    validate->add_option("--threads", validateArgs.threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));

    std::string sampleName, sampleOutput;
    bool sampleList = false;
    CLI::App* sample = app.add_subcommand("sample", "Write a generated sample volume (phantom) with known geometry");
    sample->add_option("NAME", sampleName, "sample name (see --list)");
    sample->add_option("-o,--output", sampleOutput, "output .vdb file");
    sample->add_flag("--list", sampleList, "list the samples");

    std::string infoInput;
    CLI::App* info = app.add_subcommand("info", "List the grids of a .vdb file");
    info->add_option("INPUT", infoInput, "input .vdb file")->required();

    meshArgs.owner = validateArgs.owner = benchArgs.owner = commandLine(argc, argv);
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "pipetile: usage error: %s (see pipetile --help)\n", e.what());
        return 2;
    }

    const auto outOfMemoryExit = [&] {
        std::fprintf(stderr, "pipetile: error: %s\n",
                     outOfMemory(mesh->parsed() ? &meshArgs : nullptr, validate->parsed() ? &validateArgs : nullptr).c_str());
        return 1;
    };
    try {
        if (mesh->parsed()) return runMesh(meshArgs);
        if (validate->parsed()) return runValidate(validateArgs);
        if (bench->parsed()) {
            if (!benchArgs.report.empty()) refuseClobbering({{benchArgs.input, "input volume"}}, {{benchArgs.report, "report"}});
            return pipetile::tools::runBench(benchArgs);
        }
        if (sample->parsed()) return runSample(sampleName, sampleOutput, sampleList);
        if (info->parsed()) return runInfo(infoInput);
    } catch (const pipetile::UsageError& e) {
        std::fprintf(stderr, "pipetile: usage error: %s\n", e.what());
        return 2;
    } catch (const pipetile::Error& e) {
        std::fprintf(stderr, "pipetile: error: %s\n", e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        return outOfMemoryExit();
    } catch (const std::length_error&) {
        return outOfMemoryExit();
    } catch (const std::exception& e) {
        std::fprintf(stderr, "pipetile: internal error: %s (please report it with the input)\n", e.what());
        return 1;
    }
    return 2;
}
