#include "test_util.h"

#include "phantoms.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <mutex>
#include <random>
#include <sstream>
#include <sys/wait.h>

namespace pipetile::test {

TempDir::TempDir()
{
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info ? std::string(info->test_suite_name()) + "_" + info->name() : "pipetile";
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    mPath = std::filesystem::temp_directory_path() / ("pipetile_test_" + name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(mPath);
    std::filesystem::create_directories(mPath);
}

TempDir::~TempDir()
{
    std::error_code ec;
    std::filesystem::remove_all(mPath, ec);
}

std::vector<std::string> TempDir::files() const
{
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(mPath)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

namespace {
std::string slurp(const std::string& path)
{
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
} // namespace

CliResult runCli(const std::string& args) { return runShell(std::string("'") + PIPETILE_CLI + "' " + args); }

CliResult runShell(const std::string& commandLine)
{
    static int counter = 0;
    const std::string base = (std::filesystem::temp_directory_path() /
                              ("pipetile_cli_" + std::to_string(::getpid()) + "_" + std::to_string(counter++))).string();
    const std::string command = commandLine + " > '" + base + ".out' 2> '" + base + ".err'";
    const int status = std::system(command.c_str());
    CliResult result;
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    result.out = slurp(base + ".out");
    result.err = slurp(base + ".err");
    std::filesystem::remove(base + ".out");
    std::filesystem::remove(base + ".err");
    return result;
}

const Volume& cachedSample(const std::string& name)
{
    static std::mutex mutex;
    static std::map<std::string, Volume> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(name);
    if (it == cache.end()) it = cache.emplace(name, samples::makeSample(name)).first;
    return it->second;
}

std::string realData(const std::string& file) { return std::string(PIPETILE_REAL_DATA) + "/" + file; }

std::vector<EdgeType> parseEdges(const std::string& names)
{
    static const std::map<std::string, EdgeType> types = {
        {"F", EdgeType::Forward}, {"B", EdgeType::Backward}, {"D_I", EdgeType::DownIn},
        {"D_O", EdgeType::DownOut}, {"U_I", EdgeType::UpIn}, {"U_O", EdgeType::UpOut}};
    std::vector<EdgeType> edges;
    std::istringstream in(names);
    for (std::string token; in >> token;) edges.push_back(types.at(token));
    return edges;
}

::testing::AssertionResult isClosedStrip(const std::vector<Triangle>& band, std::uint32_t m, std::uint32_t n)
{
    if (band.size() != m + n)
        return ::testing::AssertionFailure() << band.size() << " triangles, not m + n = " << m + n;
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> contourEdges;
    for (const Triangle& t : band) {
        int onA = 0;
        for (std::uint32_t v : t) onA += v < m ? 1 : 0;
        if (onA != 1 && onA != 2) return ::testing::AssertionFailure() << "a triangle on one contour only";
        for (int k = 0; k < 3; ++k)
            if ((t[k] < m) == (t[(k + 1) % 3] < m)) ++contourEdges[{t[k], t[(k + 1) % 3]}];
    }
    for (std::uint32_t i = 0; i < m; ++i)
        if (contourEdges[{i, (i + 1) % m}] != 1) return ::testing::AssertionFailure() << "edge " << i << " of A not used once";
    for (std::uint32_t j = 0; j < n; ++j)
        if (contourEdges[{m + (j + 1) % n, m + j}] != 1)
            return ::testing::AssertionFailure() << "edge " << j << " of B not used once";
    if (contourEdges.size() != m + n) return ::testing::AssertionFailure() << "edges other than the contours' used";
    auto spanning = [&](const Triangle& t) {
        std::set<std::pair<std::uint32_t, std::uint32_t>> s;
        for (int k = 0; k < 3; ++k)
            if ((t[k] < m) != (t[(k + 1) % 3] < m)) s.insert({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
        return s;
    };
    for (std::size_t k = 0; k < band.size(); ++k) {
        const auto s = spanning(band[k]), next = spanning(band[(k + 1) % band.size()]);
        int shared = 0;
        for (const auto& e : s) shared += static_cast<int>(next.count(e));
        if (shared != 1)
            return ::testing::AssertionFailure() << "triangles " << k << " and " << (k + 1) % band.size() << " share "
                                                 << shared << " spanning edges";
    }
    return ::testing::AssertionSuccess();
}

void writeGridsVdb(const std::string& path, const openvdb::GridPtrVec& grids)
{
    openvdb::initialize();
    openvdb::io::File file(path);
    file.write(grids);
    file.close();
}

void writeVectorGridVdb(const std::string& path)
{
    openvdb::initialize();
    auto grid = openvdb::Vec3SGrid::create();
    grid->setName("velocity");
    grid->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
    writeGridsVdb(path, {grid});
}

void writeEmptyGridVdb(const std::string& path)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(3.0f);
    grid->setName("empty");
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    writeGridsVdb(path, {grid});
}

void writeNanGridVdb(const std::string& path)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(3.0f);
    grid->setName("broken");
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    for (int i = 0; i < 8; ++i) grid->tree().setValue(openvdb::Coord(i, 0, 0), std::numeric_limits<float>::quiet_NaN());
    writeGridsVdb(path, {grid});
}

void writeNoisyFogVdb(const std::string& path, int size, unsigned seed)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    std::mt19937 rng(seed);
    auto accessor = grid->getAccessor();
    for (int i = 0; i < size; ++i)
        for (int j = 0; j < size; ++j)
            for (int k = 0; k < size; ++k)
                accessor.setValue(openvdb::Coord(i, j, k), static_cast<float>(rng() * (1.0 / 4294967296.0)));
    writeGridsVdb(path, {grid});
}

void writeTubeFogVdb(const std::string& path, double hotValue)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto accessor = grid->getAccessor();
    for (int i = 0; i < 24; ++i)
        for (int j = 0; j < 24; ++j)
            for (int k = 0; k < 48; ++k) {
                const double r = std::hypot(i - 11.5, j - 11.5);
                accessor.setValue(openvdb::Coord(i, j, k), static_cast<float>(std::clamp(6.5 - r, 0.0, 1.0)));
            }
    if (hotValue > 0.0) accessor.setValue(openvdb::Coord(11, 11, 20), static_cast<float>(hotValue));
    writeGridsVdb(path, {grid});
}

void writeFarSpheresVdb(const std::string& path, int zA, int zB)
{
    openvdb::initialize();
    // One sphere at the origin, copied voxel by voxel to both places: building it at z = 1e9
    // directly would lose its shape to float precision.
    const openvdb::FloatGrid::Ptr sphere = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(5.0f, openvdb::Vec3f(0.0f), 1.0f, 3.0f);
    auto grid = openvdb::FloatGrid::create(sphere->background());
    grid->setName("spheres");
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    auto accessor = grid->getAccessor();
    for (int z : {zA, zB})
        for (auto it = sphere->cbeginValueOn(); it; ++it)
            accessor.setValue(it.getCoord().offsetBy(0, 0, z), *it);
    openvdb::tools::signedFloodFill(grid->tree()); // the spheres' insides: negative, not background
    writeGridsVdb(path, {grid});
}

} // namespace pipetile::test
