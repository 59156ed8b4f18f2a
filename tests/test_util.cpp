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
#include <cstring>
#include <stdexcept>
#include <fstream>
#include <map>
#include <set>
#include <mutex>
#include <random>
#include <sstream>
#include <fcntl.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <iterator>
#include <thread>

namespace pipetile::test {

TempDir::TempDir()
{
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = info ? std::string(info->test_suite_name()) + "_" + info->name() : "pipetile";
    for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    static std::atomic<int> instances{0};
    mPath = std::filesystem::temp_directory_path() /
            ("pipetile_test_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(instances++));
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
    for (const auto& entry : std::filesystem::directory_iterator(mPath))
        names.push_back(entry.path().filename().string());
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

CliResult runCli(const std::string& args)
{
    return CliProcess(args).wait();
}

CliProcess::CliProcess(const std::string& args, const std::string& prefix)
{
    static std::atomic<int> counter{0};
    mBase = (std::filesystem::temp_directory_path() /
             ("pipetile_cli_" + std::to_string(::getpid()) + "_" + std::to_string(counter++)))
                .string();
    // exec: the shell becomes pipetile, so pid() is pipetile's own.
    const std::string command =
        prefix + " exec '" + PIPETILE_CLI + "' " + args + " > '" + mBase + ".out' 2> '" + mBase + ".err'";
    mPid = ::fork();
    if (mPid == 0) {
        // As from a terminal: signals at their defaults, whatever the test runner set.
        for (const int s : {SIGINT, SIGTERM, SIGHUP, SIGXFSZ}) std::signal(s, SIG_DFL);
        ::execl("/bin/bash", "bash", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
}

CliProcess::~CliProcess()
{
    if (mPid <= 0) return;
    if (!mReaped) ::kill(mPid, SIGKILL);
    wait();
}

bool CliProcess::running()
{
    if (mPid <= 0 || mReaped) return false;
    if (::waitpid(mPid, &mStatus, WNOHANG) == 0) return true;
    mReaped = true;
    return false;
}

CliResult CliProcess::wait()
{
    CliResult result;
    int status = mStatus;
    if (!mReaped) ::waitpid(mPid, &status, 0);
    mPid = -1;
    result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    mSignal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    result.out = slurp(mBase + ".out");
    result.err = slurp(mBase + ".err");
    std::filesystem::remove(mBase + ".out");
    std::filesystem::remove(mBase + ".err");
    return result;
}

CliResult runShell(const std::string& commandLine)
{
    static std::atomic<int> counter{0};
    const std::string base = (std::filesystem::temp_directory_path() /
                              ("pipetile_sh_" + std::to_string(::getpid()) + "_" + std::to_string(counter++)))
                                 .string();
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

bool waitForFile(const std::string& path, double seconds)
{
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    std::error_code ec;
    while (!std::filesystem::exists(path, ec)) {
        if (std::chrono::steady_clock::now() > end) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return true;
}

SmallDisk::SmallDisk(std::size_t bytes)
{
    const std::string options = "size=" + std::to_string(bytes);
    mMounted = ::mount("tmpfs", mDir.path("").c_str(), "tmpfs", 0, options.c_str()) == 0;
}

SmallDisk::~SmallDisk()
{
    if (mMounted) ::umount(mDir.path("").c_str());
}

void SmallDisk::fill()
{
    const int fd = ::open(path("filler").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const std::vector<char> block(4096, 0);
    while (::write(fd, block.data(), block.size()) > 0) {
    }
    ::close(fd);
}

void SmallDisk::unfill()
{
    std::filesystem::remove(path("filler"));
}

std::vector<glm::dvec3> plyDoubleVertices(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    std::string line;
    std::size_t count = 0, extraBytes = 0; // per vertex after x, y, z: float normals, colours
    bool doubles = false, inVertex = false;
    while (std::getline(in, line) && line != "end_header") {
        if (line.rfind("element ", 0) == 0) inVertex = line.rfind("element vertex ", 0) == 0;
        if (line.rfind("element vertex ", 0) == 0) count = std::stoul(line.substr(15));
        if (line == "property double x") doubles = true;
        if (inVertex && line.rfind("property float ", 0) == 0) extraBytes += 4;
        if (inVertex && line.rfind("property uchar ", 0) == 0) extraBytes += 1;
    }
    std::vector<glm::dvec3> vertices(doubles ? count : 0);
    for (glm::dvec3& v : vertices) {
        in.read(reinterpret_cast<char*>(&v.x), 3 * sizeof(double));
        in.ignore(static_cast<std::streamsize>(extraBytes));
    }
    return vertices;
}

std::map<std::string, std::string> folderBytes(const std::string& folder)
{
    std::map<std::string, std::string> files;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
        if (entry.is_directory()) {
            files[entry.path().filename().string()] = "(a folder)";
            continue;
        }
        std::ifstream in(entry.path(), std::ios::binary);
        files[entry.path().filename().string()] = std::string(std::istreambuf_iterator<char>(in), {});
    }
    return files;
}

::testing::AssertionResult sameFiles(const std::map<std::string, std::string>& actual,
                                     const std::map<std::string, std::string>& expected)
{
    std::string differ;
    for (const auto& [name, bytes] : expected) {
        const auto it = actual.find(name);
        if (it == actual.end())
            differ += " " + name + " (missing)";
        else if (it->second != bytes)
            differ += " " + name + " (changed)";
    }
    for (const auto& entry : actual)
        if (!expected.count(entry.first)) differ += " " + entry.first + " (extra)";
    if (differ.empty()) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "files differ:" << differ;
}

// A C-shaped section (a 270-degree arc of radius 12, 5 thick) turning `radiansPerVoxel` along z,
// over z in [16, 48]. The in-plane distance changes up to 14.5 * radiansPerVoxel times faster
// along z than a distance may, so it is divided by that bound (the zero set is the same; the
// level set's band stays valid).
Volume twistingC(double radiansPerVoxel)
{
    constexpr double pi = 3.14159265358979323846;
    const samples::DistanceFunction c = [radiansPerVoxel](const glm::dvec3& p) {
        const double turn = (p.z - 32.0) * radiansPerVoxel;
        const glm::dvec2 q(p.x - 32.0, p.y - 32.0);
        const double angle = std::atan2(q.y, q.x) - turn;
        const double wrapped = std::remainder(angle, 2.0 * pi); // (-pi, pi]: the gap is around 0
        const double gapHalf = pi / 4.0;
        double inPlane;
        if (std::abs(wrapped) > gapHalf) {
            inPlane = std::abs(glm::length(q) - 12.0) - 2.5;
        } else {
            // Nearest arc end: the ends at angles turn +- gapHalf, radius 12.
            double best = 1e9;
            for (double end : {turn + gapHalf, turn - gapHalf}) {
                const glm::dvec2 e(12.0 * std::cos(end), 12.0 * std::sin(end));
                best = std::min(best, glm::length(q - e) - 2.5);
            }
            inPlane = best;
        }
        const double lipschitz = std::sqrt(1.0 + std::pow(14.5 * radiansPerVoxel, 2.0));
        inPlane /= lipschitz;
        const double along = (std::abs(p.z - 32.0) - 16.0) / lipschitz;
        return std::max(inPlane, along) > 0.0 ? glm::length(glm::dvec2(std::max(inPlane, 0.0), std::max(along, 0.0)))
                                              : std::max(inPlane, along);
    };
    return samples::levelSetFromDistance(c, {64, 64, 64}, 1.0, "twisting C");
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

std::string realData(const std::string& file)
{
    return std::string(PIPETILE_REAL_DATA) + "/" + file;
}

std::vector<EdgeType> parseEdges(const std::string& names)
{
    static const std::map<std::string, EdgeType> types = {{"F", EdgeType::Forward},  {"B", EdgeType::Backward},
                                                          {"D_I", EdgeType::DownIn}, {"D_O", EdgeType::DownOut},
                                                          {"U_I", EdgeType::UpIn},   {"U_O", EdgeType::UpOut}};
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
        if (contourEdges[{i, (i + 1) % m}] != 1)
            return ::testing::AssertionFailure() << "edge " << i << " of A not used once";
    for (std::uint32_t j = 0; j < n; ++j)
        if (contourEdges[{m + (j + 1) % n, m + j}] != 1)
            return ::testing::AssertionFailure() << "edge " << j << " of B not used once";
    if (contourEdges.size() != m + n) return ::testing::AssertionFailure() << "edges other than the contours' used";
    auto spanning = [&](const Triangle& t) {
        std::set<std::pair<std::uint32_t, std::uint32_t>> s;
        for (int k = 0; k < 3; ++k)
            if ((t[k] < m) != (t[(k + 1) % 3] < m))
                s.insert({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
        return s;
    };
    for (std::size_t k = 0; k < band.size(); ++k) {
        const auto s = spanning(band[k]), next = spanning(band[(k + 1) % band.size()]);
        int shared = 0;
        for (const auto& e : s) shared += static_cast<int>(next.count(e));
        if (shared != 1)
            return ::testing::AssertionFailure()
                   << "triangles " << k << " and " << (k + 1) % band.size() << " share " << shared << " spanning edges";
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

const std::vector<MeshFile>& allMeshFiles()
{
    static const std::vector<MeshFile> kinds = {MeshFile::PlyAscii, MeshFile::PlyBinary, MeshFile::PlyBinaryBigEndian,
                                                MeshFile::Obj,      MeshFile::Off,       MeshFile::StlAscii,
                                                MeshFile::StlBinary};
    return kinds;
}

std::string extensionOf(MeshFile kind)
{
    switch (kind) {
    case MeshFile::PlyAscii:
    case MeshFile::PlyBinary:
    case MeshFile::PlyBinaryBigEndian: return ".ply";
    case MeshFile::Obj: return ".obj";
    case MeshFile::Off: return ".off";
    case MeshFile::StlAscii:
    case MeshFile::StlBinary: return ".stl";
    }
    return "";
}

std::string nameOf(MeshFile kind)
{
    static const char* kNames[] = {"PlyAscii", "PlyBinary", "PlyBinaryBigEndian", "Obj",
                                   "Off",      "StlAscii",  "StlBinary"};
    return kNames[static_cast<int>(kind)];
}

namespace {

// "%.17g": every double exactly, and "nan", "inf" as text formats spell them.
std::string text(double x)
{
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.17g", x);
    return buffer;
}

template <typename T>
void putBinary(std::string& out, T value, bool bigEndian)
{
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (bigEndian) std::reverse(bytes, bytes + sizeof(T)); // the tests run on little-endian machines
    out.append(bytes, sizeof(T));
}

std::string plyFile(bool ascii, bool bigEndian, const std::vector<glm::dvec3>& vertices,
                    const std::vector<std::vector<long long>>& faces)
{
    std::string out = std::string("ply\nformat ") +
                      (ascii       ? "ascii"
                       : bigEndian ? "binary_big_endian"
                                   : "binary_little_endian") +
                      " 1.0\n" + "element vertex " + std::to_string(vertices.size()) +
                      "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
                      std::to_string(faces.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const glm::dvec3& v : vertices) {
        if (ascii)
            out += text(v.x) + " " + text(v.y) + " " + text(v.z) + "\n";
        else
            for (int axis = 0; axis < 3; ++axis) putBinary<double>(out, v[axis], bigEndian);
    }
    for (const std::vector<long long>& f : faces) {
        if (ascii)
            out += std::to_string(f.size());
        else
            putBinary<std::uint8_t>(out, static_cast<std::uint8_t>(f.size()), bigEndian);
        for (long long i : f) {
            if (ascii)
                out += " " + std::to_string(i);
            else
                putBinary<std::int32_t>(out, static_cast<std::int32_t>(i), bigEndian);
        }
        if (ascii) out += "\n";
    }
    return out;
}

std::string stlFile(bool ascii, const std::vector<glm::dvec3>& vertices,
                    const std::vector<std::vector<long long>>& faces)
{
    std::string out = ascii ? "solid test\n" : std::string(80, ' ');
    if (!ascii) putBinary<std::uint32_t>(out, static_cast<std::uint32_t>(faces.size()), false);
    for (const std::vector<long long>& f : faces) {
        if (f.size() != 3) throw std::invalid_argument("STL holds triangles only");
        if (ascii)
            out += "  facet normal 0 0 0\n    outer loop\n";
        else
            for (int k = 0; k < 3; ++k) putBinary<float>(out, 0.0f, false);
        for (long long i : f) {
            const glm::dvec3& v = vertices.at(static_cast<std::size_t>(i));
            if (ascii)
                out += "      vertex " + text(v.x) + " " + text(v.y) + " " + text(v.z) + "\n";
            else
                for (int axis = 0; axis < 3; ++axis) putBinary<float>(out, static_cast<float>(v[axis]), false);
        }
        if (ascii)
            out += "    endloop\n  endfacet\n";
        else
            putBinary<std::uint16_t>(out, 0, false);
    }
    if (ascii) out += "endsolid test\n";
    return out;
}

} // namespace

void writeTextFile(const std::string& path, const std::string& text)
{
    std::ofstream out(path, std::ios::binary);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + path);
}

void writeMeshFile(const std::string& path, MeshFile kind, const std::vector<glm::dvec3>& vertices,
                   const std::vector<std::vector<long long>>& faces)
{
    std::string out;
    switch (kind) {
    case MeshFile::PlyAscii: out = plyFile(true, false, vertices, faces); break;
    case MeshFile::PlyBinary: out = plyFile(false, false, vertices, faces); break;
    case MeshFile::PlyBinaryBigEndian: out = plyFile(false, true, vertices, faces); break;
    case MeshFile::Obj:
        for (const glm::dvec3& v : vertices) out += "v " + text(v.x) + " " + text(v.y) + " " + text(v.z) + "\n";
        for (const std::vector<long long>& f : faces) {
            out += "f";
            for (long long i : f) out += " " + std::to_string(i + 1);
            out += "\n";
        }
        break;
    case MeshFile::Off:
        out = "OFF\n" + std::to_string(vertices.size()) + " " + std::to_string(faces.size()) + " 0\n";
        for (const glm::dvec3& v : vertices) out += text(v.x) + " " + text(v.y) + " " + text(v.z) + "\n";
        for (const std::vector<long long>& f : faces) {
            out += std::to_string(f.size());
            for (long long i : f) out += " " + std::to_string(i);
            out += "\n";
        }
        break;
    case MeshFile::StlAscii: out = stlFile(true, vertices, faces); break;
    case MeshFile::StlBinary: out = stlFile(false, vertices, faces); break;
    }
    writeTextFile(path, out);
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

void writeFogVoxelsVdb(const std::string& path, const glm::ivec3& dims,
                       const std::function<float(int x, int y, int z)>& density)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto accessor = grid->getAccessor();
    for (int i = 0; i < dims.x; ++i)
        for (int j = 0; j < dims.y; ++j)
            for (int k = 0; k < dims.z; ++k) accessor.setValue(openvdb::Coord(i, j, k), density(i, j, k));
    writeGridsVdb(path, {grid});
}

void writeCroppedVdb(const std::string& source, const std::string& path, const glm::ivec3& lo, const glm::ivec3& hi)
{
    openvdb::initialize();
    openvdb::io::File file(source);
    file.open();
    openvdb::FloatGrid::Ptr grid;
    for (auto name = file.beginName(); name != file.endName() && !grid; ++name)
        grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name.gridName()));
    file.close();
    if (!grid) throw std::runtime_error("no float grid in " + source);
    const openvdb::FloatGrid::Ptr crop = openvdb::FloatGrid::create(grid->background());
    crop->setName(grid->getName());
    crop->setGridClass(grid->getGridClass());
    crop->setTransform(grid->transform().copy());
    auto from = grid->getConstAccessor();
    auto to = crop->getAccessor();
    // Every value that is not the background, active or not: a level set's inside beyond its
    // narrow band is inactive at minus the background, and stays inside.
    for (int i = lo.x; i <= hi.x; ++i)
        for (int j = lo.y; j <= hi.y; ++j)
            for (int k = lo.z; k <= hi.z; ++k) {
                const openvdb::Coord ijk(i, j, k);
                if (from.isValueOn(ijk) || from.getValue(ijk) != grid->background())
                    to.setValue(ijk, from.getValue(ijk));
            }
    writeGridsVdb(path, {crop});
}

Volume realCrop(const char* file, const glm::ivec3& lo, const glm::ivec3& hi, std::optional<double> iso)
{
    TempDir dir;
    const std::string path = dir.path("crop.vdb");
    writeCroppedVdb(realData(file), path, lo, hi);
    VolumeOptions read;
    read.iso = iso;
    return readVolume(path, read);
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

void writeFarSpheresVdb(const std::string& path, const glm::ivec3& a, const glm::ivec3& b)
{
    openvdb::initialize();
    // One sphere at the origin, copied voxel by voxel to both places: building it at 1e9 voxels
    // directly would lose its shape to float precision.
    const openvdb::FloatGrid::Ptr sphere =
        openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(5.0f, openvdb::Vec3f(0.0f), 1.0f, 3.0f);
    auto grid = openvdb::FloatGrid::create(sphere->background());
    grid->setName("spheres");
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    auto accessor = grid->getAccessor();
    for (const glm::ivec3& c : {a, b})
        for (auto it = sphere->cbeginValueOn(); it; ++it) accessor.setValue(it.getCoord().offsetBy(c.x, c.y, c.z), *it);
    openvdb::tools::signedFloodFill(grid->tree()); // the spheres' insides: negative, not background
    writeGridsVdb(path, {grid});
}

} // namespace pipetile::test
