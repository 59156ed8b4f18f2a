// Shared helpers of the test suite: temporary folders, running the CLI, cached samples.
#pragma once

#include <pipetile/contour.h>
#include <pipetile/tiler.h>
#include <pipetile/volume.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace pipetile::test {

/// A fresh, empty folder for one test, removed at the end of the test.
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

/// Generated samples, made once per test process.
const Volume& cachedSample(const std::string& name);

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
void writeVectorGridVdb(const std::string& path);  // one Vec3 grid named "velocity"
void writeEmptyGridVdb(const std::string& path);   // one float level set "empty" without voxels
void writeNanGridVdb(const std::string& path);     // one float level set "broken" of NaNs

/// Volumes users have that are not clean pipes, written with OpenVDB itself.
/// A fog "density" of size^3 voxels of uniform noise in [0, 1) (mt19937 with `seed`): CT-like
/// noise at its worst, whose sections at iso 0.5 are blobs, spirals and holes.
void writeNoisyFogVdb(const std::string& path, int size, unsigned seed);
/// A fog "density" tube along z, 0 outside and 1 inside radius 6 (a 24 x 24 x 48 block, linear over
/// one voxel at the rim); `hotValue` > 0 puts one voxel of that value on the axis at z = 20.
void writeTubeFogVdb(const std::string& path, double hotValue = 0.0);
/// A level set "spheres": two spheres of radius 5 (voxel 1, half-width 3) centred at (0, 0, zA)
/// and (0, 0, zB) in index space, nothing in between.
void writeFarSpheresVdb(const std::string& path, int zA, int zB);

} // namespace pipetile::test
