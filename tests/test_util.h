// Shared helpers of the test suite: temporary folders, running the CLI, cached samples.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/tiler.h>
#include <pipetile/volume.h>

#include <glm/vec3.hpp>
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

// Built with AddressSanitizer (gcc or clang): its shadow memory cannot live under an
// address-space limit, so tests that set one skip.
#if defined(__SANITIZE_ADDRESS__)
#define PIPETILE_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PIPETILE_TEST_ASAN 1
#endif
#endif

namespace pipetile::test {

/// A fresh, empty folder for one test, removed at the end of the test (each instance its own).
class TempDir {
public:
    TempDir();
    ~TempDir();
    std::string path(const std::string& name) const { return (mPath / name).string(); }
    std::vector<std::string> files() const; // names of the files in it, sorted

private:
    std::filesystem::path mPath;
};

struct CliResult {
    int exitCode = -1;
    std::string out, err;
};

/// Runs the pipetile executable with `args` (shell-quoted by the caller where needed).
CliResult runCli(const std::string& args);
/// Runs a whole /bin/sh command line (a pipeline, `bash -c ...`), capturing its output likewise.
CliResult runShell(const std::string& commandLine);

/// A pipetile process started in the background, for tests that signal it or run two at once.
/// `prefix` goes before the executable in the shell command (for example "ulimit -f 16;").
class CliProcess {
public:
    explicit CliProcess(const std::string& args, const std::string& prefix = "");
    ~CliProcess(); // kills the process if the test did not wait for it
    int pid() const { return mPid; }
    bool running();
    CliResult wait(); // exitCode -1 when a signal ended it, see signal()
    int signal() const { return mSignal; }

private:
    int mPid = -1;
    int mStatus = 0;
    bool mReaped = false; // running() saw it end
    int mSignal = 0;
    std::string mBase; // where stdout and stderr go
};

/// Polls (every millisecond, up to `seconds`) until `path` exists; false if it never does.
bool waitForFile(const std::string& path, double seconds = 60.0);

/// A tmpfs of `bytes` mounted on a folder of its own, unmounted at the end: a small disk that
/// fills up. Mounting needs root; mounted() says whether it worked.
class SmallDisk {
public:
    explicit SmallDisk(std::size_t bytes);
    ~SmallDisk();
    bool mounted() const { return mMounted; }
    std::string path(const std::string& name) const { return mDir.path(name); }
    std::vector<std::string> files() const { return mDir.files(); }
    void fill();   // a file "filler" takes every free byte
    void unfill(); // and is removed

private:
    TempDir mDir;
    bool mMounted = false;
};

/// The vertices of a binary PLY with double x, y, z (then float and uchar properties) as pipetile
/// writes it, read byte by byte
/// (OpenMesh's reader rounds them to float).
std::vector<glm::dvec3> plyDoubleVertices(const std::string& path);

/// Every file of a folder (hidden ones included) with its bytes; "(a folder)" for folders.
std::map<std::string, std::string> folderBytes(const std::string& folder);

/// Whether two folders' files (folderBytes) are the same; on failure names the files that differ
/// (not their bytes, which may be megabytes).
::testing::AssertionResult sameFiles(const std::map<std::string, std::string>& actual,
                                     const std::map<std::string, std::string>& expected);

/// Generated samples, made once per test process.
const Volume& cachedSample(const std::string& name);

/// A C-shaped section (a 270-degree arc of radius 12, 5 thick) turning `radiansPerVoxel` along
/// z, over z in [16, 48], as a level set of 64^3 voxels: sections that overlap in part only
/// from one slice to the next, and whose ends move (graph and quality tests).
Volume twistingC(double radiansPerVoxel);

/// A real third-party volume from ../shared/data/real.
std::string realData(const std::string& file);

/// Edge types from their names, e.g. "F U_I B U_O F".
std::vector<EdgeType> parseEdges(const std::string& names);

/// Acceptable surface (toroidal graph sense) between contours of m and n crossings (ids i and
/// m + j): m + n triangles, each with one contour edge and one vertex on the other contour; every
/// contour edge used exactly once; consecutive triangles sharing one spanning edge, the last with
/// the first (a closed strip).
::testing::AssertionResult isClosedStrip(const std::vector<Triangle>& band, std::uint32_t m, std::uint32_t n);

/// Small broken .vdb files, written with OpenVDB itself, for bad-input tests.
void writeVectorGridVdb(const std::string& path); // one Vec3 grid named "velocity"
void writeEmptyGridVdb(const std::string& path);  // one float level set "empty" without voxels
void writeNanGridVdb(const std::string& path);    // one float level set "broken" of NaNs

/// Mesh files written byte by byte rather than through a library, so that they can hold what no
/// writer would: NaN coordinates, bad indices, non-manifold faces.
enum class MeshFile {
    PlyAscii,
    PlyBinary,          // little endian; double x, y, z; list uchar int vertex_indices
    PlyBinaryBigEndian, // the same, big endian
    Obj,                // indices written from 1: index i becomes i + 1
    Off,
    StlAscii,  // triangles only; each corner written out by its coordinates
    StlBinary, // the same, as float32
};
const std::vector<MeshFile>& allMeshFiles();
std::string extensionOf(MeshFile kind); // ".ply", ...
std::string nameOf(MeshFile kind);      // "PlyAscii", ... for SCOPED_TRACE
void writeMeshFile(const std::string& path, MeshFile kind, const std::vector<glm::dvec3>& vertices,
                   const std::vector<std::vector<long long>>& faces);
void writeTextFile(const std::string& path, const std::string& text);
/// Volumes users have that are not clean pipes, written with OpenVDB itself.
/// A fog "density" of size^3 voxels of uniform noise in [0, 1) (mt19937 with `seed`): CT-like
/// noise at its worst, whose sections at iso 0.5 are blobs, spirals and holes.
void writeNoisyFogVdb(const std::string& path, int size, unsigned seed);
/// A fog "density" tube along z, 0 outside and 1 inside radius 6 (a 24 x 24 x 48 block, linear over
/// one voxel at the rim); `hotValue` > 0 puts one voxel of that value on the axis at z = 20.
void writeTubeFogVdb(const std::string& path, double hotValue = 0.0);
/// A fog "density" over [0, dims), every voxel active, of the value `density` gives it.
void writeFogVoxelsVdb(const std::string& path, const glm::ivec3& dims,
                       const std::function<float(int x, int y, int z)>& density);
/// The first float grid of `source`, only its voxels inside the index box [lo, hi] that are active
/// or hold another value than the background (a level set's inside) kept,
/// written to `path` with the same name, class and transform: a piece of real data.
void writeCroppedVdb(const std::string& source, const std::string& path, const glm::ivec3& lo, const glm::ivec3& hi);
/// The index box [lo, hi] of the shared real volume `file` (writeCroppedVdb), read at `iso` (none:
/// the grid's default).
Volume realCrop(const char* file, const glm::ivec3& lo, const glm::ivec3& hi, std::optional<double> iso);
/// A level set "spheres": two spheres of radius 5 (voxel 1, half-width 3) centred at `a` and `b`
/// in index space, nothing in between.
void writeFarSpheresVdb(const std::string& path, const glm::ivec3& a, const glm::ivec3& b);

} // namespace pipetile::test
