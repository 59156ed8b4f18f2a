// pipetile — the command line: parse, call the library, print, map exceptions to exit codes.
// Exit codes: 0 ok, 1 a failure (the message names the file or grid and what to do), 2 usage.

#include <pipetile/pipetile.h>

#include "bench.h"
#include "frame.h"
#include "html_report.h"
#include "phantoms.h"
#include "progress.h"
#include "report.h"
#include "sequence.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <malloc.h>
#include <pthread.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <map>
#include <future>
#include <memory>
#include <new>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;
using pipetile::tools::checkWritableTarget;
using pipetile::tools::NamedPath;
using pipetile::tools::noteIsovalue;
using pipetile::tools::openOutputs;
using pipetile::tools::outputsExist;
using pipetile::tools::refuseClobbering;

void printNote(const char* kind, const std::string& text)
{
    std::fprintf(stderr, "pipetile: %s: %s\n", kind, text.c_str());
}

double secondsSince(Clock::time_point start)
{
    return std::chrono::duration<double>(Clock::now() - start).count();
}

void writeJson(const json& report, pipetile::OutputSet& outputs, const std::string& path)
{
    outputs.write(path, [&](std::ostream& out) { out << pipetile::tools::reportText(report, 2) << '\n'; });
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
    auto count = [](long long n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); };
    std::vector<std::string> parts;
    if (t.nonManifoldEdges > 0)
        parts.push_back(count(t.nonManifoldEdges, "non-manifold edge") + " (in 3 or more triangles; one joins " +
                        at(t.firstNonManifoldEdge[0]) + " and " + at(t.firstNonManifoldEdge[1]) + ")");
    if (t.nonManifoldVertices > 0)
        parts.push_back(count(t.nonManifoldVertices, "non-manifold vertex") +
                        " (where separate fans of triangles meet; one at " + at(t.firstNonManifoldVertex) + ")");
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

std::string formatNumber(double v)
{
    std::ostringstream os;
    os << v;
    return os.str();
}

// --units: the grid's world unit in metres (glTF's unit).
double metresPerUnit(const std::string& units)
{
    static const std::map<std::string, double> kUnits = {{"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"um", 1e-6}};
    return kUnits.at(units);
}

// --html: refused before any work when this build has no page, or its folder is missing.
void checkHtmlTarget(const std::string& path)
{
    if (path.empty()) return;
    pipetile::tools::checkHtmlReportAvailable(path);
    checkWritableTarget(path, "HTML report");
}

struct MeshArgs {
    std::string input, output, grid, report, frames, summary, html;
    std::string units = "m"; // the grid's world unit, for the .glb (glTF is in metres)
    std::optional<double> iso;
    std::string axis = "auto";
    double spacing = 2.0;
    int rays = 8, levels = 4, threads = 0;
    bool validate = false, everySlice = false, skipExisting = false;
    std::string tiler = "contour-tree";
    std::string owner; // the command line, for a concurrent run's message
};

// Ends the process once its work is done and its outputs committed, without tearing down what
// it built: freeing a large grid and its meshes node by node only to exit took a tenth of a run.
[[noreturn]] void exitNow(int code)
{
    std::fflush(nullptr);
    std::_Exit(code);
}

// The job of meshing one input (a file, a frame, or the phantom when `input` is empty).
pipetile::tools::FrameJob frameJob(const MeshArgs& args, const std::string& input, const std::string& output,
                                   const std::string& report)
{
    pipetile::tools::FrameJob job;
    job.input = input;
    job.output = output;
    job.report = report;
    job.owner = args.owner;
    pipetile::MeshOptions& options = job.options;
    options.slicing.spacingVoxels = args.spacing;
    options.slicing.axis = args.axis == "x"   ? pipetile::Axis::X
                           : args.axis == "y" ? pipetile::Axis::Y
                           : args.axis == "z" ? pipetile::Axis::Z
                                              : pipetile::Axis::Auto;
    options.baseRays = args.rays;
    options.levels = args.levels;
    options.threads = args.threads;
    options.everySlice = args.everySlice;
    options.tiler = args.tiler == "optimal"  ? pipetile::TilerKind::Optimal
                    : args.tiler == "greedy" ? pipetile::TilerKind::Greedy
                                             : pipetile::TilerKind::ContourTree;
    job.metresPerUnit = metresPerUnit(args.units);
    job.volume.gridName = args.grid;
    job.volume.iso = args.iso;
    job.notify = printNote;
    return job;
}

void printLevels(const pipetile::Volume& volume, const pipetile::Reconstruction& reconstruction,
                 const std::vector<pipetile::LevelMesh>& levels, const json& report)
{
    const pipetile::ReconstructionStats& stats = reconstruction.stats();
    std::printf("%s  grid '%s' (%s, iso %g), axis %s, %d slices, %d contours in %d tubes\n", volume.source().c_str(),
                pipetile::printableName(volume.gridName()).c_str(), pipetile::toString(volume.volumeClass()),
                volume.iso(), pipetile::tools::axisName(reconstruction.plan().axis), stats.slices, stats.contours,
                stats.tubes);
    std::printf("%5s %6s %10s %10s %9s  %s\n", "level", "rays", "vertices", "triangles", "seconds", "file");
    for (std::size_t k = 0; k < levels.size(); ++k)
        std::printf("%5d %6d %10zu %10zu %9.4f  %s\n", levels[k].level, levels[k].rays, levels[k].mesh.vertices.size(),
                    levels[k].mesh.triangles.size(), levels[k].seconds,
                    report["levels"][k]["file"].get<std::string>().c_str());
}

// Adds a validation block to every level of the report; prints the table when `print`. With
// `nested` levels (a .glb or an HTML report), each level is validated as its nested mesh, the same
// mesh renumbered, so that the finest level's vertex errors fit the .glb's vertex array.
void validateLevels(const pipetile::Volume& volume, const std::vector<pipetile::LevelMesh>& levels,
                    const pipetile::NestedLevels& nested, json& report, pipetile::GlbOptions& glb, int threads,
                    bool print)
{
    // One reference isosurface for all levels; its time is the same-run peer of ours.
    const pipetile::Validator validator(volume, {1.0, threads});
    if (print) {
        std::printf("\nvalidation against volumeToMesh (%zu triangles, %.4f s):\n",
                    validator.reference().triangles.size(), validator.referenceSeconds());
        printValidationHeader();
    }
    const bool nest = !nested.vertexCounts.empty();
    for (std::size_t k = 0; k < levels.size(); ++k) {
        const pipetile::Validation v =
            nest ? validator.validate(pipetile::tools::nestedMesh(nested, k)) : validator.validate(levels[k].mesh);
        if (nest && k + 1 == levels.size()) glb.vertexError = v.vertexDistance;
        report["levels"][k]["validation"] = pipetile::tools::validationReport(v);
        if (print) printValidationRow("L" + std::to_string(levels[k].level), v);
    }
}

int runMesh(const MeshArgs& args)
{
    const std::string output =
        !args.output.empty()
            ? args.output
            : (args.input.empty() ? std::string("phantom") : std::filesystem::path(args.input).stem().string()) +
                  ".ply";
    pipetile::tools::FrameJob job = frameJob(args, args.input, output, args.report);
    if (args.skipExisting && outputsExist(job.output, job.report, job.options.levels)) {
        std::printf("%s: its outputs exist, skipped (--skip-existing)\n", output.c_str());
        return 0;
    }
    if (args.input.empty())
        job.read = [&] {
            pipetile::Volume phantom = pipetile::samples::makeSample("phantom");
            if (args.iso) throw pipetile::UsageError("--iso needs an INPUT file");
            return phantom;
        };
    // A large volume takes a while per level: a bar on a terminal (a log keeps its lines as they were).
    std::optional<pipetile::tools::Progress> progress;
    if (::isatty(STDERR_FILENO)) {
        progress.emplace(args.levels, "levels", true);
        job.levelDone = [&](int level, int) { progress->step("level " + std::to_string(level - 1)); };
    }
    job.html = args.html;
    job.beforeCommit = [&](const pipetile::Volume& volume, const pipetile::Reconstruction& reconstruction,
                           const std::vector<pipetile::LevelMesh>& levels, const pipetile::NestedLevels& nested,
                           json& report, pipetile::GlbOptions& glb) {
        progress.reset();
        printLevels(volume, reconstruction, levels, report);
        if (args.validate) validateLevels(volume, levels, nested, report, glb, args.threads, true);
    };
    job.committed = [] { exitNow(0); };
    pipetile::tools::meshFrame(job);
    return 0;
}

struct ValidateArgs {
    std::string input, mesh, grid, report, colors, html, owner;
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
    checkHtmlTarget(args.html);
    std::vector<NamedPath> outputs;
    if (!args.colors.empty()) outputs.push_back({args.colors, "coloured mesh"});
    if (!args.report.empty()) outputs.push_back({args.report, "report"});
    if (!args.html.empty()) outputs.push_back({args.html, "HTML report"});
    refuseClobbering({{args.input, "input volume"}, {args.mesh, "mesh to validate"}}, outputs);
    const std::unique_ptr<pipetile::OutputSet> files = openOutputs(outputs, args.owner, printNote);
    pipetile::VolumeOptions volumeOptions;
    volumeOptions.gridName = args.grid;
    volumeOptions.iso = args.iso;
    const pipetile::Volume volume = pipetile::readVolume(args.input, volumeOptions);
    noteIsovalue(volume, printNote);
    const pipetile::TriangleMesh mesh = pipetile::readMesh(args.mesh);
    if (mesh.triangles.empty())
        throw pipetile::Error("'" + args.mesh + "': the mesh has " + std::to_string(mesh.vertices.size()) +
                              " vertices and no faces; nothing to validate");
    const pipetile::Validator validator(volume, {1.0, args.threads});
    const pipetile::Validation v = validator.validate(mesh);
    std::printf("%s against the isosurface of %s, grid '%s' at iso %g (volumeToMesh: %zu triangles, %.4f s)\n",
                args.mesh.c_str(), args.input.c_str(), pipetile::printableName(volume.gridName()).c_str(), volume.iso(),
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
        json report = {{"input", args.input},
                       {"grid", volume.gridName()},
                       {"iso", volume.iso()},
                       {"mesh", args.mesh},
                       {"vertices", mesh.vertices.size()},
                       {"triangles", mesh.triangles.size()},
                       {"validation", pipetile::tools::validationReport(v)}};
        writeJson(report, *files, args.report);
    }
    if (!args.html.empty()) {
        // The mesh as the page's one level, its vertices coloured by their distance.
        const pipetile::NestedLevels one{mesh.vertices, {mesh.vertices.size()}, {mesh.triangles}};
        pipetile::tools::HtmlReport html;
        html.title = "pipetile validate: " + args.mesh;
        html.subtitle = "against the isosurface of " + args.input + ", grid '" +
                        pipetile::printableName(volume.gridName()) + "' at iso " + formatNumber(volume.iso());
        html.levels = json::array({{{"name", std::filesystem::path(args.mesh).filename().string()},
                                    {"vertices", mesh.vertices.size()},
                                    {"triangles", mesh.triangles.size()},
                                    {"seconds", v.seconds},
                                    {"validation", pipetile::tools::validationReport(v)}}});
        html.voxel = v.voxel;
        pipetile::GlbOptions glb;
        glb.vertexError = v.vertexDistance;
        pipetile::tools::writeHtmlReport(*files, args.html, html, one, glb);
    }
    files->commit();
    if (!args.colors.empty())
        std::printf("wrote %s: blue on the isosurface, red at 1 voxel or more\n", args.colors.c_str());
    return 0;
}

int runSample(const std::string& name, const std::string& output, bool list)
{
    if (list || name.empty()) {
        for (const pipetile::samples::SampleInfo& s : pipetile::samples::sampleList())
            std::printf("%-14s %4d x %4d x %4d  %s\n", s.name.c_str(), s.dims.x, s.dims.y, s.dims.z,
                        s.description.c_str());
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

// Backs the heap with transparent huge pages where the kernel grants them on request
// (transparent_hugepage=madvise, Debian's default): reading a volume allocates a node at a time,
// and a page fault per 4 KiB page of them cost a fifth of a run's CPU on the phantom. The heap is
// grown once by kHugeHeap and that span advised (what glibc's glibc.malloc.hugetlb=1 tunable does,
// which a program cannot set for itself); where malloc is not glibc's heap (sanitizers) the heap
// does not grow and nothing is advised. Under a limit on the address space or the heap (ulimit -v,
// -d) nothing changes either: the padding would spend a large part of a tight limit, and the
// places that then ran out first (glibc loading its unwinder for a thread's exit) abort.
void adviseHugePageHeap()
{
    for (const int resource : {RLIMIT_AS, RLIMIT_DATA}) {
        rlimit limit{};
        if (getrlimit(resource, &limit) != 0 || limit.rlim_cur != RLIM_INFINITY) return;
    }
    constexpr std::size_t kHugeHeap = std::size_t(64) << 20, kHugePage = std::size_t(2) << 20;
    // Requests up to 32 MiB from the heap rather than mmap, and the heap kept grown, not trimmed.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, static_cast<int>(2 * kHugeHeap));
    mallopt(M_TOP_PAD, static_cast<int>(kHugeHeap));
    const auto before = reinterpret_cast<std::uintptr_t>(sbrk(0));
    void* volatile probe = std::malloc(kHugePage); // volatile: the pair must not be optimized away
    std::free(probe);
    const auto after = reinterpret_cast<std::uintptr_t>(sbrk(0));
    const std::uintptr_t start = (before + kHugePage - 1) & ~(kHugePage - 1);
    if (before == std::uintptr_t(-1) || after < start + kHugeHeap / 2) return;
    madvise(reinterpret_cast<void*>(start), after - start, MADV_HUGEPAGE);
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
        std::fprintf(stderr,
                     "pipetile: stopped by %s; this run's files are removed, earlier outputs are as they were\n",
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

// Which resource an exception says ran out: memory (std::bad_alloc, or a container asked for more
// than it can hold), or a thread that could not start for want of address space or processes
// (std::thread's std::system_error, TBB's "pthread_create has failed" std::runtime_error).
enum class Exhausted { Nothing, Memory, Threads };

Exhausted exhausted(const std::exception& e)
{
    if (dynamic_cast<const std::bad_alloc*>(&e) || dynamic_cast<const std::length_error*>(&e)) return Exhausted::Memory;
    if (const auto* failure = dynamic_cast<const std::system_error*>(&e))
        if (failure->code() == std::errc::resource_unavailable_try_again ||
            failure->code() == std::errc::not_enough_memory)
            return Exhausted::Threads;
    if (std::strncmp(e.what(), "pthread_create has failed", 25) == 0) return Exhausted::Threads;
    return Exhausted::Nothing;
}

// What to tell a user whose run ran out of memory or threads: which run, and what makes it smaller.
std::string outOfMemory(const MeshArgs* mesh, const ValidateArgs* validate, Exhausted what = Exhausted::Memory)
{
    const bool threads = what == Exhausted::Threads;
    const std::string ranOut =
        threads ? "out of memory for a new thread (or the process limit, ulimit -u, is reached)" : "out of memory";
    if (mesh) {
        const std::string input = mesh->input.empty() ? std::string("the phantom") : "'" + mesh->input + "'";
        return ranOut + " meshing " + input + " with --levels " + std::to_string(mesh->levels) + ", --rays " +
               std::to_string(mesh->rays) + ", --spacing " + formatNumber(mesh->spacing) + ": " +
               (threads ? "use fewer --threads, " : "") +
               "lower --levels or --rays, raise --spacing, or clip the grid to the object";
    }
    if (validate)
        return ranOut + " validating '" + validate->mesh + "' against '" + validate->input +
               "': " + (threads ? "use fewer --threads; " : "") +
               "the isosurface of the whole grid and the mesh must fit; clip the grid to the object or "
               "validate a coarser level";
    return ranOut + ": use a smaller grid (clip it to the object) or fewer levels";
}

// Resources that run out where no catch sees them end in std::terminate: a thread a library starts
// before main (log4cplus, under OpenVDB), a TBB worker starting another, a destructor that
// allocates while an earlier std::bad_alloc unwinds (OpenVDB's Tree::clear). There the run is
// abandoned as on a signal, so nothing of it stays, and it exits 1 with its command's message
// (set once the command line is parsed; plain pointers, as the handler may run before any
// constructor of this file). Any other exception keeps the default diagnosis and abort.
const char* gMemoryMessage = nullptr;
const char* gThreadsMessage = nullptr;
std::terminate_handler gDefaultTerminate = nullptr;

[[noreturn]] void exitOnExhaustion()
{
    Exhausted what = Exhausted::Nothing;
    if (const std::exception_ptr current = std::current_exception()) {
        try {
            std::rethrow_exception(current);
        } catch (const std::exception& e) {
            what = exhausted(e);
        } catch (...) {
        }
    }
    if (what == Exhausted::Nothing) {
        if (gDefaultTerminate) gDefaultTerminate();
        std::abort();
    }
    pipetile::abandonOutputs();
    const char* message = what == Exhausted::Threads ? gThreadsMessage : gMemoryMessage;
    if (!message)
        message = "out of memory starting pipetile (a thread or buffer of its libraries could not be made): the "
                  "address-space limit (ulimit -v) or the process limit (ulimit -u) is too small; raise it";
    std::fprintf(stderr, "pipetile: error: %s\n", message);
    std::_Exit(1);
}

void setExhaustionMessages(const MeshArgs* mesh, const ValidateArgs* validate)
{
    static const std::string memory = outOfMemory(mesh, validate, Exhausted::Memory);
    static const std::string threads = outOfMemory(mesh, validate, Exhausted::Threads);
    gMemoryMessage = memory.c_str();
    gThreadsMessage = threads.c_str();
}

// Installed from the executable's preinit array, which runs before the shared libraries'
// constructors, so that a thread log4cplus cannot start there ends in the message too.
void installTerminateHandler(int, char**, char**)
{
    gDefaultTerminate = std::set_terminate(exitOnExhaustion);
}
__attribute__((used,
               section(".preinit_array"))) void (*const gInstallTerminateHandler)(int, char**,
                                                                                  char**) = installTerminateHandler;

// The pattern of a sequence's outputs (-o, --report): it must hold the frame number too.
std::optional<pipetile::tools::FramePattern> outputPattern(const std::string& text, const char* option)
{
    if (text.empty()) return std::nullopt;
    std::optional<pipetile::tools::FramePattern> pattern = pipetile::tools::FramePattern::parse(text);
    if (!pattern)
        throw pipetile::UsageError(std::string(option) + " '" + text +
                                   "': the input is a sequence, so each frame needs " +
                                   "its own file; put the frame number in it (####, $F4 or %04d)");
    return pattern;
}

// Reads a frame on a thread of its own, while the frame before it is meshed.
std::future<pipetile::Volume> readAhead(const std::string& path, const pipetile::VolumeOptions& options)
{
    return std::async(std::launch::async, [path, options] { return pipetile::readVolume(path, options); });
}

// Meshes one frame of a sequence; a failure is the frame's, told in one line, and the run goes on.
pipetile::tools::FrameOutcome meshSequenceFrame(const MeshArgs& args, pipetile::tools::FrameJob job, int frame,
                                                std::future<pipetile::Volume>& volume,
                                                pipetile::tools::Progress& progress)
{
    pipetile::tools::FrameOutcome outcome{frame, job.input, "meshed", "", {}};
    const std::string name = "frame " + std::to_string(frame);
    job.notify = [&](const char* kind, const std::string& text) {
        progress.print(std::string("pipetile: ") + kind + ": " + name + ": " + text);
    };
    job.read = [&] { return volume.get(); };
    job.beforeCommit = [&](const pipetile::Volume& v, const pipetile::Reconstruction&,
                           const std::vector<pipetile::LevelMesh>& levels, const pipetile::NestedLevels& nested,
                           json& report, pipetile::GlbOptions& glb) {
        if (args.validate) validateLevels(v, levels, nested, report, glb, args.threads, false);
    };
    MeshArgs frameArgs = args;
    frameArgs.input = job.input;
    try {
        outcome.report = pipetile::tools::meshFrame(job);
    } catch (const pipetile::Error& e) {
        outcome.error = pipetile::tools::frameError(frame, e.what());
    } catch (const std::exception& e) {
        const Exhausted what = exhausted(e);
        outcome.error =
            pipetile::tools::frameError(frame, what != Exhausted::Nothing ? outOfMemory(&frameArgs, nullptr, what)
                                                                          : std::string("internal error: ") + e.what() +
                                                                                " (please report it with the input)");
    }
    if (!outcome.error.empty()) {
        outcome.status = "failed";
        progress.print("pipetile: error: " + outcome.error);
    } else {
        const json& finest = outcome.report["levels"].back();
        char line[64];
        std::snprintf(line, sizeof line, ", %lld triangles at level %d, %.3f s", finest["triangles"].get<long long>(),
                      finest["level"].get<int>(), outcome.report["seconds"].get<double>());
        progress.print(name + ": " + job.input + " -> " + job.output + line, stdout);
    }
    progress.step(name, !outcome.error.empty());
    return outcome;
}

// `pipetile mesh 'sim/smoke.####.vdb' [--frames A-B[:step]] -o 'out/smoke.####.ply'`: every frame
// in one process, each frame its own transaction, the next frame read while this one is meshed.
int runSequence(const MeshArgs& args, const pipetile::tools::FramePattern& input)
{
    const Clock::time_point start = Clock::now();
    const std::string defaultOutput = std::filesystem::path(input.text()).stem().string() + ".ply";
    const pipetile::tools::FramePattern output =
        *outputPattern(args.output.empty() ? defaultOutput : args.output, "-o");
    const std::optional<pipetile::tools::FramePattern> report = outputPattern(args.report, "--report");
    if (!args.html.empty())
        throw pipetile::UsageError(
            "--html writes one page for one input; a sequence has a report per frame (--report)");
    const std::vector<int> frames =
        args.frames.empty() ? input.existingFrames() : pipetile::tools::parseFrameRange(args.frames);
    if (frames.empty())
        throw pipetile::Error("'" + input.text() + "': no file matches; check the name, or give --frames A-B");
    std::unique_ptr<pipetile::OutputSet> summary;
    if (!args.summary.empty()) {
        pipetile::tools::checkWritableTarget(args.summary, "summary");
        summary = pipetile::tools::openOutputs({{args.summary, "summary"}}, args.owner, printNote);
    }

    // Frames whose outputs all exist are done (--skip-existing); the others are meshed in order.
    std::vector<pipetile::tools::FrameOutcome> outcomes;
    std::vector<std::pair<int, pipetile::tools::FrameJob>> jobs;
    for (const int frame : frames) {
        pipetile::tools::FrameJob job =
            frameJob(args, input.path(frame), output.path(frame), report ? report->path(frame) : "");
        if (args.skipExisting && outputsExist(job.output, job.report, job.options.levels))
            outcomes.push_back({frame, job.input, "skipped", "", {}});
        else
            jobs.emplace_back(frame, std::move(job));
    }
    if (!jobs.empty()) pipetile::checkMeshOptions(jobs.front().second.options); // a usage error once, not per frame
    pipetile::tools::Progress progress(static_cast<int>(jobs.size()), "frames", ::isatty(STDERR_FILENO));
    std::future<pipetile::Volume> next;
    if (!jobs.empty()) next = readAhead(jobs.front().second.input, jobs.front().second.volume);
    for (std::size_t k = 0; k < jobs.size(); ++k) {
        std::future<pipetile::Volume> volume = std::move(next);
        if (k + 1 < jobs.size()) next = readAhead(jobs[k + 1].second.input, jobs[k + 1].second.volume);
        outcomes.push_back(meshSequenceFrame(args, jobs[k].second, jobs[k].first, volume, progress));
    }
    std::sort(outcomes.begin(), outcomes.end(), [](const auto& a, const auto& b) { return a.frame < b.frame; });

    const json aggregate = pipetile::tools::sequenceReport(input.text(), output.text(), outcomes, secondsSince(start));
    progress.print(std::to_string(outcomes.size()) + " frames: " + std::to_string(aggregate["meshed"].get<int>()) +
                       " meshed, " + std::to_string(aggregate["skipped"].get<int>()) + " skipped (outputs exist), " +
                       std::to_string(aggregate["failed"].get<int>()) + " failed, in " +
                       formatNumber(aggregate["seconds"].get<double>()) + " s",
                   stdout);
    if (summary) {
        writeJson(aggregate, *summary, args.summary);
        summary->commit();
    }
    return aggregate["failed"].get<int>() > 0 ? 1 : 0;
}

} // namespace

int main(int argc, char** argv)
{
    adviseHugePageHeap();
    handleSignalsInOneThread();
    CLI::App app{"pipetile: multiresolution triangle meshes of pipe-shaped objects from OpenVDB volumes"};
    app.require_subcommand(1);

    MeshArgs meshArgs;
    CLI::App* mesh = app.add_subcommand("mesh", "Mesh a .vdb volume (default: the bundled phantom) at several levels");
    mesh->add_option("INPUT", meshArgs.input, "input .vdb file; omitted: the bundled 'phantom' sample");
    mesh->add_option("-o,--output", meshArgs.output,
                     "output mesh; level k goes to NAME_L<k>.EXT (.ply .obj .stl .off), or all levels into one .glb");
    mesh->add_option("--units", meshArgs.units, "the grid's world unit, for the .glb (glTF is in metres)")
        ->check(CLI::IsMember({"m", "cm", "mm", "um"}));
    mesh->add_option("--html", meshArgs.html, "write an HTML report: the levels in 3D, their table");
    mesh->add_option("--grid", meshArgs.grid, "grid name (default: the first float grid)");
    mesh->add_option("--iso", meshArgs.iso,
                     "isovalue (default: 0 for level sets; fog: halfway from background to max)");
    mesh->add_option("--axis", meshArgs.axis, "slicing axis")->check(CLI::IsMember({"x", "y", "z", "auto"}));
    mesh->add_option("--spacing", meshArgs.spacing, "slice spacing in voxels")->check(CLI::Range(0.1, 1000.0));
    mesh->add_option("--rays", meshArgs.rays, "rays at level 0 (n0)")->check(CLI::Range(3, 4096));
    mesh->add_option("--levels", meshArgs.levels, "levels of detail")->check(CLI::Range(1, 16));
    mesh->add_option("--report", meshArgs.report, "write a JSON report");
    mesh->add_option("--threads", meshArgs.threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));
    mesh->add_flag("--validate", meshArgs.validate, "compare every level with volumeToMesh's isosurface");
    mesh->add_option("--tiler", meshArgs.tiler, "tiler: the paper's contour trees, or a toroidal baseline")
        ->check(CLI::IsMember({"contour-tree", "optimal", "greedy"}));
    mesh->add_option("--frames", meshArgs.frames,
                     "frames A-B[:STEP] of a sequence INPUT such as 'sim/smoke.####.vdb' ($F4, %04d); default: "
                     "the files that exist");
    mesh->add_flag("--skip-existing", meshArgs.skipExisting, "skip a frame whose outputs all exist (resumes a run)");
    mesh->add_option("--summary", meshArgs.summary, "write the aggregate JSON report of a sequence");
    mesh->add_flag("--every-slice", meshArgs.everySlice,
                   "tile every slice at every level, as the paper does (default: coarse levels skip the slices "
                   "their neighbours predict within the level's own error)");

    pipetile::tools::BenchArgs benchArgs;
    CLI::App* bench = app.add_subcommand("bench", "Time pipetile against its baselines and volumeToMesh on one grid");
    bench->add_option("INPUT", benchArgs.input, "input .vdb file; omitted: the bundled 'phantom' sample");
    bench->add_option("--report", benchArgs.report, "write the figures as JSON");
    bench->add_option("--html", benchArgs.html, "write an HTML report: the levels in 3D, error against triangles");
    bench->add_option("--repeat", benchArgs.repeat, "repetitions per figure (median reported)")
        ->check(CLI::Range(1, 1000));
    bench->add_option("--threads", benchArgs.threads, "worker threads (0: all cores)")->check(CLI::Range(0, 1024));

    ValidateArgs validateArgs;
    CLI::App* validate = app.add_subcommand("validate", "Compare any mesh with the isosurface of a .vdb volume");
    validate->add_option("INPUT", validateArgs.input, "input .vdb file")->required();
    validate->add_option("MESH", validateArgs.mesh, "mesh file (.ply .obj .stl .off), from pipetile or any tool")
        ->required();
    validate->add_option("--grid", validateArgs.grid, "grid name (default: the first float grid)");
    validate->add_option("--iso", validateArgs.iso, "isovalue (default as for mesh)");
    validate->add_option("--report", validateArgs.report, "write a JSON report");
    validate->add_option("--error-colors", validateArgs.colors, "write the mesh as .ply coloured by its distance");
    validate->add_option("--html", validateArgs.html, "write an HTML report: the mesh in 3D coloured by its distance");
    validate->add_option("--threads", validateArgs.threads, "worker threads (0: all cores)")
        ->check(CLI::Range(0, 1024));

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

    const MeshArgs* meshParsed = mesh->parsed() ? &meshArgs : nullptr;
    const ValidateArgs* validateParsed = validate->parsed() ? &validateArgs : nullptr;
    setExhaustionMessages(meshParsed, validateParsed);
    try {
        if (mesh->parsed()) {
            if (const auto sequence = pipetile::tools::FramePattern::parse(meshArgs.input))
                return runSequence(meshArgs, *sequence);
            if (!meshArgs.frames.empty() || !meshArgs.summary.empty())
                throw pipetile::UsageError(std::string(meshArgs.frames.empty() ? "--summary" : "--frames") +
                                           " is for a sequence: name the input with its frame number as ####, $F4 or "
                                           "%04d (for example 'sim/smoke.####.vdb')");
            return runMesh(meshArgs);
        }
        if (validate->parsed()) return runValidate(validateArgs);
        if (bench->parsed()) {
            std::vector<NamedPath> outputs;
            if (!benchArgs.report.empty()) outputs.push_back({benchArgs.report, "report"});
            if (!benchArgs.html.empty()) outputs.push_back({benchArgs.html, "HTML report"});
            refuseClobbering({{benchArgs.input, "input volume"}}, outputs);
            checkHtmlTarget(benchArgs.html);
            return pipetile::tools::runBench(benchArgs);
        }
        if (sample->parsed()) return runSample(sampleName, sampleOutput, sampleList);
        if (info->parsed()) return runInfo(infoInput);
    } catch (const pipetile::UsageError& e) {
        std::fprintf(stderr, "pipetile: usage error: %s\n", pipetile::withSettings(e, "--", "").c_str());
        return 2;
    } catch (const pipetile::InternalError& e) {
        std::fprintf(stderr, "pipetile: internal error: %s (please report it with the input)\n", e.what());
        return 1;
    } catch (const pipetile::Error& e) {
        std::fprintf(stderr, "pipetile: error: %s\n", pipetile::withSettings(e, "--", "").c_str());
        return 1;
    } catch (const std::exception& e) {
        if (const Exhausted what = exhausted(e); what != Exhausted::Nothing)
            std::fprintf(stderr, "pipetile: error: %s\n", outOfMemory(meshParsed, validateParsed, what).c_str());
        else
            std::fprintf(stderr, "pipetile: internal error: %s (please report it with the input)\n", e.what());
        return 1;
    }
    return 2;
}
