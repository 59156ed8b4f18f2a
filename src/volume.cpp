// pipetile — volume: reading a .vdb, picking the grid, level set vs fog, isovalue, transform.

#include <pipetile/error.h>
#include <pipetile/volume_grid.h>

#include <pipetile/output_set.h>

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Dense.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <new>
#include <sstream>
#include <streambuf>
#include <vector>

namespace pipetile {

namespace {

void initializeOpenVdb()
{
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

std::string inQuotes(const std::string& s)
{
    return "'" + s + "'";
}

std::string nameInQuotes(const std::string& name)
{
    return inQuotes(printableName(name));
}

std::string formatValue(double v)
{
    std::ostringstream os;
    os << v;
    return os.str();
}

std::string gridClassName(openvdb::GridClass c)
{
    switch (c) {
    case openvdb::GRID_LEVEL_SET: return "level set";
    case openvdb::GRID_FOG_VOLUME: return "fog volume";
    case openvdb::GRID_STAGGERED: return "staggered";
    default: return "unknown";
    }
}

const char* fileKind(std::filesystem::file_type type)
{
    switch (type) {
    case std::filesystem::file_type::fifo: return "pipe (FIFO, or a shell's <(...))";
    case std::filesystem::file_type::character: return "character device";
    case std::filesystem::file_type::block: return "block device";
    case std::filesystem::file_type::socket: return "socket";
    default: return "special file";
    }
}

// OpenVDB's message about a file, for the user: a damaged file can put megabytes of its bytes in
// it (a fuzzed .vdb: building the message itself ran out of memory), so it is cut short, without
// copying the rest.
std::string libraryMessage(const std::exception& e)
{
    constexpr std::size_t kLongest = 300;
    const char* what = e.what();
    const std::size_t length = strnlen(what, kLongest + 1);
    return length > kLongest ? std::string(what, kLongest) + "..." : std::string(what, length);
}

// Memory ran out while reading: the grid is too large for what this process may use, or a damaged
// file claims more data than it holds (OpenVDB allocates what the file declares before reading it).
Error outOfMemoryReading(const std::string& path, const std::string& what)
{
    return Error(inQuotes(path) + ": out of memory reading " + what +
                 "; the grid needs more memory than this process may use (raise the limit, ulimit -v, or clip the "
                 "grid to the object), or the file is damaged and claims more data than it holds");
}

// Refuses what is not a regular file, before anything opens it (opening a pipe would block).
void checkReadable(const std::string& path)
{
    initializeOpenVdb();
    std::error_code ec;
    const std::filesystem::file_status status = std::filesystem::status(path, ec);
    if (!std::filesystem::exists(status)) throw Error(inQuotes(path) + ": no such file; check the path");
    if (std::filesystem::is_directory(status)) throw Error(inQuotes(path) + ": is a directory, not a .vdb file");
    // OpenVDB seeks in the file and pipetile opens it twice (grid list, then voxels): a pipe would
    // be half consumed by the first reader, and the second would wait forever for a writer.
    if (!std::filesystem::is_regular_file(status))
        throw Error(inQuotes(path) + ": is a " + fileKind(status.type()) +
                    ", not a regular file; .vdb files are read by seeking: save the data to a file first");
}

// Opens a file for reading and turns OpenVDB's exceptions into messages a user can act on.
std::unique_ptr<openvdb::io::File> openFile(const std::string& path)
{
    checkReadable(path);
    auto file = std::make_unique<openvdb::io::File>(path);
    try {
        file->open(/*delayLoad=*/false);
    } catch (const std::bad_alloc&) {
        throw outOfMemoryReading(path, "it");
    } catch (const std::exception& e) {
        throw Error(inQuotes(path) + ": not a readable VDB file (" + libraryMessage(e) +
                    "); check that it is a complete .vdb written by OpenVDB 3 or later");
    }
    return file;
}

// The grids a message lists: the first 20 (a damaged file can claim thousands), and how many more.
std::string listNames(const std::vector<GridSummary>& grids)
{
    constexpr std::size_t kListed = 20;
    std::string s;
    for (std::size_t i = 0; i < std::min(grids.size(), kListed); ++i) {
        if (!s.empty()) s += ", ";
        s += nameInQuotes(grids[i].name) + " (" + grids[i].valueType + ")";
    }
    if (grids.size() > kListed) s += ", and " + std::to_string(grids.size() - kListed) + " more";
    return s.empty() ? "none" : s;
}

GridSummary summarize(const openvdb::GridBase& grid)
{
    GridSummary s;
    s.name = grid.getName();
    s.valueType = grid.valueType();
    s.gridClass = gridClassName(grid.getGridClass());
    const openvdb::Vec3d vs = grid.voxelSize();
    s.voxelSize = glm::dvec3(vs.x(), vs.y(), vs.z());
    if (auto count = grid.getMetadata<openvdb::Int64Metadata>(openvdb::GridBase::META_FILE_VOXEL_COUNT))
        s.activeVoxels = count->value();
    auto bmin = grid.getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MIN);
    auto bmax = grid.getMetadata<openvdb::Vec3IMetadata>(openvdb::GridBase::META_FILE_BBOX_MAX);
    if (bmin && bmax) {
        s.bboxMin = glm::ivec3(bmin->value().x(), bmin->value().y(), bmin->value().z());
        s.bboxMax = glm::ivec3(bmax->value().x(), bmax->value().y(), bmax->value().z());
    }
    return s;
}

std::vector<GridSummary> summarizeGrids(openvdb::io::File& file, const std::string& path)
{
    std::vector<GridSummary> grids;
    try {
        const openvdb::GridPtrVecPtr metadata = file.readAllGridMetadata();
        for (const openvdb::GridBase::Ptr& g : *metadata) grids.push_back(summarize(*g));
    } catch (const std::bad_alloc&) {
        throw outOfMemoryReading(path, "its grid descriptions");
    } catch (const std::exception& e) {
        throw Error(inQuotes(path) + ": cannot read the grid descriptions (" + libraryMessage(e) +
                    "); the file may be truncated or damaged");
    }
    return grids;
}

// OpenVDB trusts the node counts and child masks in a file and allocates every node before it
// reads its contents; its file reader does not stop at the end of the data, so a damaged 12 KB file
// can ask for 2^20 nodes of 270 KB. Read through a stream that throws on any read past the end,
// and the reading stops at the first node the file holds no bytes for. io::Stream reads every
// grid of the file, so this is done for files up to kBoundedReadBytes (the grids of such a file
// fit in memory anyway); larger files, and files with a grid of a type this OpenVDB does not
// know, are read grid by grid by io::File, trusting them.
constexpr std::uintmax_t kBoundedReadBytes = std::uintmax_t(256) << 20;

/// A read-only stream buffer over bytes in memory, seekable: io::Stream reads a file in many small
/// pieces, and a file stream paid a system call for each seek; the file is read once instead.
class MemoryBuffer : public std::streambuf {
public:
    explicit MemoryBuffer(std::vector<char>& bytes) { setg(bytes.data(), bytes.data(), bytes.data() + bytes.size()); }

protected:
    pos_type seekoff(off_type offset, std::ios_base::seekdir dir, std::ios_base::openmode) override
    {
        const off_type base = dir == std::ios_base::beg   ? 0
                              : dir == std::ios_base::cur ? gptr() - eback()
                                                          : egptr() - eback();
        return seekpos(pos_type(base + offset), std::ios_base::in);
    }
    pos_type seekpos(pos_type position, std::ios_base::openmode) override
    {
        const off_type at = off_type(position);
        if (at < 0 || at > egptr() - eback()) return pos_type(off_type(-1));
        setg(eback(), eback() + at, egptr());
        return position;
    }
};

/// The grids of a file read whole, and the file's format version.
struct FileGrids {
    openvdb::GridPtrVecPtr grids;
    std::uint32_t fileVersion = 0;
};

/// Every grid of a file of up to kBoundedReadBytes, read from memory; grids null for a larger file.
/// Lets OpenVDB's exceptions and std::ios_base::failure (the data ends early) through.
FileGrids readFileGrids(const std::string& path)
{
    std::error_code ec;
    const std::uintmax_t size = std::filesystem::file_size(path, ec);
    if (ec || size > kBoundedReadBytes) return {};
    std::vector<char> bytes(static_cast<std::size_t>(size));
    std::ifstream file(path, std::ios::binary);
    if (!file.read(bytes.data(), static_cast<std::streamsize>(size)))
        throw Error(inQuotes(path) + ": cannot read it (" + std::strerror(errno) + ")");
    MemoryBuffer buffer(bytes);
    std::istream in(&buffer);
    in.exceptions(std::ios::failbit | std::ios::badbit | std::ios::eofbit);
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    return {stream.getGrids(), stream.fileVersion()};
}

openvdb::GridBase::Ptr readGridBounded(const std::string& path, const std::string& name)
{
    try {
        const openvdb::GridPtrVecPtr grids = readFileGrids(path).grids;
        if (!grids) return nullptr;
        for (const openvdb::GridBase::Ptr& grid : *grids)
            if (grid->getName() == name) return grid;
    } catch (const openvdb::LookupError&) {
        // Another grid of a type this OpenVDB does not know: read only ours, through io::File.
        return nullptr;
    } catch (const std::ios_base::failure&) {
        throw Error(inQuotes(path) + ": cannot read grid " + nameInQuotes(name) +
                    ": the file ends before the grid's data does; it is truncated or damaged");
    }
    throw Error(inQuotes(path) + ": grid " + nameInQuotes(name) + " could not be read back");
}

/// The grid readVolume meshes, from one read of the whole file, when that read settles it: the
/// grid named `requested`, else the first float grid, as the io::File path would pick them. Null
/// when that path must decide: a large file, a grid type this OpenVDB does not know, a damaged or
/// ancient file, or any choice that ends in a message (that path words them). For files without
/// grid offsets (io::Stream writes none) io::File::open read every grid before the bounded read
/// read them again, through a seek per node.
openvdb::FloatGrid::Ptr readChosenGridAtOnce(const std::string& path, const std::string& requested)
{
    FileGrids file;
    try {
        file = readFileGrids(path);
    } catch (const std::exception&) {
        return nullptr;
    }
    // io::File's readAllGridMetadata refuses these.
    if (!file.grids || file.fileVersion < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) return nullptr;
    std::string name = requested;
    if (name.empty()) {
        // io::File lists a file's grids by name (a std::multimap) when the file has grid offsets,
        // in file order when not: the first float grid in file order is its pick either way only
        // if no other float grid's name sorts before it.
        const openvdb::GridBase* first = nullptr;
        for (const openvdb::GridBase::Ptr& grid : *file.grids) {
            if (grid->valueType() != "float") continue;
            if (!first)
                first = grid.get();
            else if (grid->getName() < first->getName())
                return nullptr;
        }
        if (!first) return nullptr;
        name = first->getName();
    }
    // The first grid of that name, as readGridBounded returns it; null if it is not a float grid.
    for (const openvdb::GridBase::Ptr& grid : *file.grids)
        if (grid->getName() == name) return openvdb::gridPtrCast<openvdb::FloatGrid>(grid);
    return nullptr;
}

Error nonFiniteError(const std::string& where, long long count, bool finiteBackground, const char* what)
{
    return Error(where + ": holds " + std::to_string(count) + " NaN or infinite values" +
                 (finiteBackground ? "" : " (and a non-finite background)") + "; repair the " + what +
                 " (e.g. clamp it) before meshing");
}

// OpenVDB's matrices act on row vectors (translation in the last row): the transpose of `m`.
openvdb::math::Transform::Ptr transformOf(const glm::dmat4& m, const std::string& where)
{
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r]))
                throw UsageError(where + ": the index-to-world matrix holds a non-finite value");
    if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
        throw UsageError(where + ": the index-to-world matrix's last row must be (0, 0, 0, 1), world = M (i, j, k, 1); "
                                 "a matrix for row vectors, as OpenVDB's, must be transposed");
    openvdb::math::Mat4d rows;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) rows(r, c) = m[r][c];
    const double det = rows.getMat3().det();
    if (!(std::abs(det) > 0.0))
        throw UsageError(where + ": the index-to-world matrix is singular (its voxels have no volume)");
    return openvdb::math::Transform::createLinearTransform(rows);
}

// Calls f(value) for every active value of a grid whose active values all lie in leaf nodes (as
// volumeFromGrid's grids do: it voxelizes active tiles first), a leaf's value mask at a time: the
// tree-wide value iterator cost more than the rest of these passes over every active voxel.
template <typename F>
void forEachActiveVoxel(const openvdb::FloatGrid& grid, F&& f)
{
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
        const float* values = leaf->buffer().data();
        for (auto on = leaf->getValueMask().beginOn(); on; ++on) f(values[on.pos()]);
    }
}

// The default fog isovalue: halfway between the background (empty space) and the densest value,
// 0.5 for a 0..1 density and -500 for a CT-like -1000..0 volume, unless so few voxels are that
// dense that fewer than kFewestObjectVoxels would lie inside: then the densest value that leaves
// that many (one voxel at 100 in a 0..1 tube would put the surface at 50, around that voxel
// alone). The answer is one of the kFewestObjectVoxels densest values, since each of them lies
// beyond halfway to itself. `hot` gets the number of voxels denser than the value taken.
double defaultFogIso(const openvdb::FloatGrid& grid, long long& hot)
{
    const double background = grid.background();
    std::vector<float> densest; // a min-heap of the densest values
    forEachActiveVoxel(grid, [&](float value) {
        if (static_cast<long long>(densest.size()) < kFewestObjectVoxels) {
            densest.push_back(value);
            std::push_heap(densest.begin(), densest.end(), std::greater<float>());
        } else if (value > densest.front()) {
            std::pop_heap(densest.begin(), densest.end(), std::greater<float>());
            densest.back() = value;
            std::push_heap(densest.begin(), densest.end(), std::greater<float>());
        }
    });
    std::sort(densest.begin(), densest.end(), std::greater<float>());
    // Voxels beyond the isovalue halfway to each candidate, counted in one pass.
    std::vector<double> isos;
    for (float peak : densest) isos.push_back(0.5 * (background + peak)); // decreasing
    std::vector<long long> beyond(isos.size(), 0);
    forEachActiveVoxel(grid, [&](float value) {
        // isos[k] < value for k >= first: the first k with isos[k] < value, isos decreasing.
        const auto first = std::partition_point(isos.begin(), isos.end(), [&](double iso) { return iso >= value; });
        if (first != isos.end()) ++beyond[first - isos.begin()];
    });
    long long count = 0; // voxels beyond isos[k]: those beyond isos[0..k]
    for (std::size_t k = 0; k < isos.size() && densest[k] > background; ++k) {
        count += beyond[k];
        if (count >= kFewestObjectVoxels) {
            hot = std::count_if(densest.begin(), densest.end(), [&](float v) { return v > densest[k]; });
            return isos[k];
        }
    }
    hot = 0; // too few voxels to be an object at any of them: the densest value (callers warn)
    return isos.front();
}

// volumeToMesh takes a fog voxel at the isovalue itself for the dense side, and meshes one whose
// 26 neighbours all lie below as a component of no size (8 points at one spot; 2 of the gaffer
// smoke's 19 half-float voxels at its halfway value): a default isovalue that makes one moves to
// the next float above, where none does. A voxel at the isovalue next to a denser one only
// places the surface on it (the cone's CT values at -500).
double offVoxelValues(const openvdb::FloatGrid& grid, double iso)
{
    const float at = static_cast<float>(iso);
    const openvdb::FloatGrid::ConstAccessor accessor = grid.getConstAccessor();
    const auto speck = [&](const openvdb::Coord& c) {
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if ((dx | dy | dz) != 0 && !(accessor.getValue(c.offsetBy(dx, dy, dz)) < at)) return false;
        return true;
    };
    for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf)
        for (auto on = leaf->cbeginValueOn(); on; ++on)
            if (*on == at && speck(on.getCoord()))
                return static_cast<double>(std::nextafter(at, std::numeric_limits<float>::infinity()));
    return iso;
}

long long countInside(const openvdb::FloatGrid& grid, VolumeClass volumeClass, double iso)
{
    long long inside = 0;
    forEachActiveVoxel(grid, [&](float value) {
        inside += (volumeClass == VolumeClass::LevelSet ? value < iso : value >= iso) ? 1 : 0; // as volumeToMesh
    });
    return inside;
}

} // namespace

const char* toString(VolumeClass volumeClass)
{
    return volumeClass == VolumeClass::LevelSet ? "level set" : "fog volume";
}

const std::string& Volume::source() const
{
    return mImpl->source;
}
const std::string& Volume::gridName() const
{
    return mImpl->gridName;
}
VolumeClass Volume::volumeClass() const
{
    return mImpl->volumeClass;
}
double Volume::iso() const
{
    return mImpl->iso;
}
double Volume::background() const
{
    return mImpl->grid->background();
}
double Volume::minValue() const
{
    return mImpl->minValue;
}
double Volume::maxValue() const
{
    return mImpl->maxValue;
}
long long Volume::insideVoxels() const
{
    return mImpl->insideVoxels;
}
long long Volume::hotVoxels() const
{
    return mImpl->hotVoxels;
}

glm::dvec3 Volume::voxelSize() const
{
    const openvdb::Vec3d v = mImpl->grid->voxelSize();
    return {v.x(), v.y(), v.z()};
}

double Volume::smallestVoxel() const
{
    const glm::dvec3 v = voxelSize();
    return std::min(v.x, std::min(v.y, v.z));
}

glm::ivec3 Volume::bboxMin() const
{
    const openvdb::Coord c = mImpl->bbox.min();
    return {c.x(), c.y(), c.z()};
}

glm::ivec3 Volume::bboxMax() const
{
    const openvdb::Coord c = mImpl->bbox.max();
    return {c.x(), c.y(), c.z()};
}

glm::dvec3 Volume::indexToWorld(const glm::dvec3& index) const
{
    const openvdb::Vec3d w = mImpl->grid->transform().indexToWorld(openvdb::Vec3d(index.x, index.y, index.z));
    return {w.x(), w.y(), w.z()};
}

glm::dvec3 Volume::worldToIndex(const glm::dvec3& world) const
{
    const openvdb::Vec3d i = mImpl->grid->transform().worldToIndex(openvdb::Vec3d(world.x, world.y, world.z));
    return {i.x(), i.y(), i.z()};
}

bool Volume::mirrored() const
{
    const openvdb::Vec3d o = mImpl->grid->transform().indexToWorld(openvdb::Vec3d(0.0));
    const openvdb::Vec3d ex = mImpl->grid->transform().indexToWorld(openvdb::Vec3d(1, 0, 0)) - o;
    const openvdb::Vec3d ey = mImpl->grid->transform().indexToWorld(openvdb::Vec3d(0, 1, 0)) - o;
    const openvdb::Vec3d ez = mImpl->grid->transform().indexToWorld(openvdb::Vec3d(0, 0, 1)) - o;
    return ex.cross(ey).dot(ez) < 0.0;
}

double Volume::signedField(const glm::dvec3& world) const
{
    const openvdb::Vec3d index = mImpl->grid->transform().worldToIndex(openvdb::Vec3d(world.x, world.y, world.z));
    const double v = openvdb::tools::BoxSampler::sample(mImpl->grid->tree(), index);
    return mImpl->volumeClass == VolumeClass::LevelSet ? v - mImpl->iso : mImpl->iso - v;
}

bool Volume::surfaceWithin(const glm::dvec3& world, double radius) const
{
    const openvdb::Vec3d index = mImpl->grid->transform().worldToIndex(openvdb::Vec3d(world.x, world.y, world.z));
    // Not registered with the tree (a registered accessor's bookkeeping was most of the cost).
    const openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> accessor(mImpl->grid->tree());
    const bool above = openvdb::tools::BoxSampler::sample(accessor, index) > mImpl->iso;
    // The faces' directions first, then the edges', then the corners': a surface across an axis
    // shows at the first few.
    for (int nonzero = 1; nonzero <= 3; ++nonzero)
        for (int x = -1; x <= 1; ++x)
            for (int y = -1; y <= 1; ++y)
                for (int z = -1; z <= 1; ++z) {
                    if ((x != 0) + (y != 0) + (z != 0) != nonzero) continue;
                    const openvdb::Vec3d direction = openvdb::Vec3d(x, y, z).unitSafe();
                    for (const double r : {0.5 * radius, radius})
                        if ((openvdb::tools::BoxSampler::sample(accessor, index + r * direction) > mImpl->iso) != above)
                            return true;
                }
    return false;
}

glm::dvec3 Volume::fieldGradient(const glm::dvec3& world) const
{
    const openvdb::math::Transform& transform = mImpl->grid->transform();
    const openvdb::Vec3d index = transform.worldToIndex(openvdb::Vec3d(world.x, world.y, world.z));
    const openvdb::FloatGrid::ConstAccessor accessor = mImpl->grid->getConstAccessor();
    // Half a voxel either side: the difference spans the cell around the point and its neighbours,
    // which smooths the trilinear field's kinks at cell faces.
    constexpr double kStep = 0.5;
    openvdb::Vec3d gradient;
    for (int axis = 0; axis < 3; ++axis) {
        openvdb::Vec3d step(0.0);
        step[axis] = kStep;
        gradient[axis] = (openvdb::tools::BoxSampler::sample(accessor, index + step) -
                          openvdb::tools::BoxSampler::sample(accessor, index - step)) /
                         (2.0 * kStep);
    }
    // The signed field is value - iso for level sets and iso - value for fog volumes.
    if (mImpl->volumeClass == VolumeClass::Fog) gradient = -gradient;
    const openvdb::Vec3d g = transform.baseMap()->applyIJT(gradient, index);
    return {g.x(), g.y(), g.z()};
}

std::string printableName(const std::string& name)
{
    constexpr std::size_t kLongest = 100;
    std::string shown;
    for (std::size_t i = 0; i < std::min(name.size(), kLongest); ++i) {
        const unsigned char c = static_cast<unsigned char>(name[i]);
        if (c >= 0x20 && c != 0x7f) {
            shown += static_cast<char>(c);
            continue;
        }
        char escaped[5];
        std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
        shown += escaped;
    }
    return name.size() > kLongest ? shown + "..." : shown;
}

std::vector<GridSummary> listGrids(const std::string& path)
{
    return summarizeGrids(*openFile(path), path);
}

Volume readVolume(const std::string& path, const VolumeOptions& options)
{
    checkReadable(path);
    if (openvdb::FloatGrid::Ptr grid = readChosenGridAtOnce(path, options.gridName))
        return volumeFromGrid(grid, options, path);

    auto file = openFile(path);
    const std::vector<GridSummary> grids = summarizeGrids(*file, path);
    if (grids.empty()) throw Error(inQuotes(path) + ": holds no grids; nothing to mesh");

    std::string name = options.gridName;
    if (name.empty()) {
        // The first float grid, whatever its name: pyopenvdb and others write grids named ''.
        const auto first =
            std::find_if(grids.begin(), grids.end(), [](const GridSummary& g) { return g.valueType == "float"; });
        if (first == grids.end())
            throw Error(inQuotes(path) + ": holds no scalar float grid (grids: " + listNames(grids) +
                        "); pipetile meshes float level sets and fog volumes");
        name = first->name;
    } else {
        const auto it = std::find_if(grids.begin(), grids.end(), [&](const GridSummary& g) { return g.name == name; });
        if (it == grids.end())
            throw Error(inQuotes(path) + ": has no grid named " + nameInQuotes(name) + " (grids: " + listNames(grids) +
                            "); pick one by name",
                        {Setting::Grid});
        if (it->valueType != "float")
            throw Error(inQuotes(path) + ": grid " + nameInQuotes(name) + " holds " + it->valueType +
                            " values, not float; pick a scalar float grid by name (grids: " + listNames(grids) + ")",
                        {Setting::Grid});
    }

    openvdb::GridBase::Ptr base;
    try {
        base = readGridBounded(path, name);
        if (!base) base = file->readGrid(name);
    } catch (const Error&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw outOfMemoryReading(path, "grid " + nameInQuotes(name));
    } catch (const std::exception& e) {
        throw Error(inQuotes(path) + ": cannot read grid " + nameInQuotes(name) + " (" + libraryMessage(e) +
                    "); the file may be truncated or damaged");
    }
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid)
        throw Error(inQuotes(path) + ": grid " + nameInQuotes(name) + " is not a float grid; pick another by name",
                    {Setting::Grid});
    return volumeFromGrid(grid, options, path);
}

Volume volumeFromGrid(openvdb::FloatGrid::ConstPtr input, const VolumeOptions& options, const std::string& source)
{
    initializeOpenVdb();
    const std::string where = inQuotes(source) + ", grid " + nameInQuotes(input->getName());
    if (input->tree().activeVoxelCount() == 0)
        throw Error(where + ": the grid is empty (no active voxels); nothing to mesh");

    // Boundaries must lie in leaf nodes, where the slicer looks for them (fog volumes often hold
    // constant active tiles inside); voxelizing a copy keeps the caller's grid untouched.
    openvdb::FloatGrid::ConstPtr grid = input;
    if (input->tree().activeTileCount() > 0) {
        // Voxelizing costs memory per voxel of every tile: refuse what would not fit.
        constexpr openvdb::Index64 kMaxTileVoxels = openvdb::Index64(1) << 28; // ~1 GiB of floats
        openvdb::Index64 tileVoxels = 0;
        for (auto it = input->cbeginValueOn(); it && tileVoxels <= kMaxTileVoxels; ++it)
            if (!it.isVoxelValue()) tileVoxels += it.getVoxelCount();
        if (tileVoxels > kMaxTileVoxels)
            throw Error(where + ": its active tiles cover more than " + std::to_string(kMaxTileVoxels) +
                        " voxels; pipetile voxelizes them to find the surface: clip the grid to the object or "
                        "deactivate the constant regions first");
        openvdb::FloatGrid::Ptr copy = input->deepCopy();
        copy->tree().voxelizeActiveTiles();
        grid = copy;
    }

    const double background = grid->background();
    double lo = background, hi = background;
    long long nonFinite = 0;
    forEachActiveVoxel(*grid, [&](float value) {
        const double v = value;
        if (!std::isfinite(v)) {
            ++nonFinite;
            return;
        }
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    });
    if (nonFinite > 0 || !std::isfinite(background))
        throw nonFiniteError(where, nonFinite, std::isfinite(background), "grid");

    auto impl = std::make_shared<Volume::Impl>();
    impl->grid = grid;
    impl->source = source;
    impl->gridName = input->getName();
    impl->minValue = lo;
    impl->maxValue = hi;
    impl->bbox = grid->evalActiveVoxelBoundingBox();

    // Class: the grid's own metadata decides; an unclassified grid whose background is positive
    // and whose values go negative reads as a signed distance field.
    const openvdb::GridClass gc = grid->getGridClass();
    if (gc == openvdb::GRID_LEVEL_SET)
        impl->volumeClass = VolumeClass::LevelSet;
    else if (gc == openvdb::GRID_FOG_VOLUME)
        impl->volumeClass = VolumeClass::Fog;
    else
        impl->volumeClass = (background > 0.0 && lo < 0.0) ? VolumeClass::LevelSet : VolumeClass::Fog;

    if (options.iso) {
        if (!std::isfinite(*options.iso)) throw UsageError(where + ": the isovalue must be a finite number");
        impl->iso = *options.iso;
    } else if (impl->volumeClass == VolumeClass::LevelSet) {
        impl->iso = 0.0;
    } else {
        impl->iso = offVoxelValues(*grid, defaultFogIso(*grid, impl->hotVoxels));
    }
    const double iso = impl->iso;
    impl->insideVoxels = countInside(*grid, impl->volumeClass, iso);
    if (!(lo < iso && iso < hi))
        throw Error(where + ": isovalue " + formatValue(iso) + " crosses nothing (values range from " +
                        formatValue(lo) + " to " + formatValue(hi) + "); choose an isovalue inside that range",
                    {Setting::Iso});
    const bool backgroundInside = impl->volumeClass == VolumeClass::LevelSet ? background < iso : background > iso;
    if (backgroundInside)
        throw Error(where + ": the background value " + formatValue(background) + " lies inside the surface at iso " +
                        formatValue(iso) + ", so the object is unbounded; check the grid class (" +
                        toString(impl->volumeClass) + ") or choose another isovalue",
                    {Setting::Iso});
    return Volume(impl);
}

Volume volumeFromDense(const DenseVolume& dense, const VolumeOptions& options, const std::string& source)
{
    initializeOpenVdb();
    const std::string where = inQuotes(source);
    if (dense.dims.x <= 0 || dense.dims.y <= 0 || dense.dims.z <= 0)
        throw UsageError(where + ": a dense volume needs at least one voxel along each axis");
    if (!dense.values) throw UsageError(where + ": no values");
    const openvdb::math::Transform::Ptr transform = transformOf(dense.indexToWorld, where);

    // The background is the value of empty space: the largest of a signed distance field, the
    // smallest of a density. NaN would compare as neither and vanish into it, so it is refused here.
    const std::size_t count = std::size_t(dense.dims.x) * std::size_t(dense.dims.y) * std::size_t(dense.dims.z);
    const bool levelSet = dense.volumeClass == VolumeClass::LevelSet;
    float background = 0.0f;
    long long nonFinite = 0;
    bool first = true;
    for (std::size_t n = 0; n < count; ++n) {
        const float v = dense.values[n];
        if (!std::isfinite(v)) {
            ++nonFinite;
            continue;
        }
        if (first || (levelSet ? v > background : v < background)) background = v;
        first = false;
    }
    if (nonFinite > 0) throw nonFiniteError(where, nonFinite, true, "array");

    const openvdb::CoordBBox box(openvdb::Coord(0),
                                 openvdb::Coord(dense.dims.x - 1, dense.dims.y - 1, dense.dims.z - 1));
    // LayoutZYX: z varies fastest, numpy's C order for array[x, y, z]. copyFromDense only reads.
    const openvdb::tools::Dense<float, openvdb::tools::LayoutZYX> block(box, const_cast<float*>(dense.values));
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(background);
    openvdb::tools::copyFromDense(block, *grid, /*tolerance=*/0.0f);
    grid->setTransform(transform);
    grid->setGridClass(levelSet ? openvdb::GRID_LEVEL_SET : openvdb::GRID_FOG_VOLUME);
    grid->setName(options.gridName);
    return volumeFromGrid(grid, options, source);
}

void writeVolume(const Volume& volume, const std::string& path)
{
    initializeOpenVdb();
    OutputSet outputs({path});
    // Through a stream (io::File writes to a file of its own, unchecked): io::File reads it back.
    outputs.write(path,
                  [&](std::ostream& out) { openvdb::io::Stream(out).write(openvdb::GridCPtrVec{volume.impl().grid}); });
    outputs.commit();
}

} // namespace pipetile
