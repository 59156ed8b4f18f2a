// pipetile — volume: reading a .vdb, picking the grid, level set vs fog, isovalue, transform.
//
// This header is free of OpenVDB so that most of the library compiles quickly; the OpenVDB side of
// the module (building a Volume from a grid a caller already has) is in volume_grid.h.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pipetile {

/// How the values of a grid relate to the object it describes.
enum class VolumeClass {
    LevelSet, // signed distance: inside where value < iso (default iso 0)
    Fog,      // density: inside where value >= iso (volumeToMesh parts the two sides by value < iso)
};

/// Fewer active voxels than this (a 3 x 3 x 3 block) inside a surface make specks, not an object:
/// the default fog isovalue keeps at least this many inside, and callers warn below it.
constexpr long long kFewestObjectVoxels = 27;

struct VolumeOptions {
    std::string gridName;      // empty: the first scalar float grid of the file
    std::optional<double> iso; // unset: 0 for level sets; for fog volumes, halfway between the
                               // background and the largest active value that leaves at least
                               // kFewestObjectVoxels inside (so one hot voxel cannot set it),
                               // or the next float above where a voxel holding that value
                               // exactly has no neighbour as dense (documented in README)
};

/// Name, type and class of one grid in a file, as `pipetile info` lists them.
struct GridSummary {
    std::string name;
    std::string valueType; // "float", "vec3s", ...
    std::string gridClass; // "level set", "fog volume", "unknown"
    long long activeVoxels = 0;
    glm::ivec3 bboxMin{0}, bboxMax{0}; // active voxel bounding box, index space, inclusive
    glm::dvec3 voxelSize{1.0};
};

/// A scalar float grid chosen from a file, with its class and isovalue. Cheap to copy (shared): a
/// copy keeps the grid alive, and copies may be read from any number of threads. A
/// default-constructed Volume is empty (valid() false); every other member requires valid().
/// The signed field `f = (value - iso)` for level sets and `f = (iso - value)` for fog volumes is
/// negative inside the object for both classes; everything downstream works with that field (a
/// slice takes a fog voxel at the isovalue itself for a hair inside, as volumeToMesh does).
class Volume {
public:
    struct Impl;

    Volume() = default;
    explicit Volume(std::shared_ptr<const Impl> impl) : mImpl(std::move(impl)) {}

    const std::string& source() const; // file path, or "sample:<name>"
    const std::string& gridName() const;
    VolumeClass volumeClass() const;
    double iso() const;
    glm::dvec3 voxelSize() const; // world units per voxel along x, y, z of index space
    double smallestVoxel() const; // smallest voxel edge, the unit of "voxels" in reports
    glm::ivec3 bboxMin() const;   // active voxel bounding box, index space, inclusive
    glm::ivec3 bboxMax() const;
    double background() const; // the value of empty space (inactive voxels)
    double minValue() const;   // over active values and the background
    double maxValue() const;
    /// Active voxels inside the surface at iso(): below kFewestObjectVoxels the mesh is specks.
    long long insideVoxels() const;
    /// Active voxels denser than the value the default fog isovalue was taken from: so few that,
    /// taken as the object, fewer than kFewestObjectVoxels would lie inside (one hot voxel in a
    /// 0..1 density). 0 when the isovalue was given, for level sets, and when no voxel was left out.
    long long hotVoxels() const;
    /// World position of a point given in index space (the grid's own transform).
    glm::dvec3 indexToWorld(const glm::dvec3& index) const;
    glm::dvec3 worldToIndex(const glm::dvec3& world) const;
    /// True when the index-to-world map mirrors space (negative determinant): triangle winding
    /// computed in index space must then be reversed to keep normals outward in world space.
    bool mirrored() const;
    /// The signed field (negative inside) at a world point, trilinearly interpolated.
    double signedField(const glm::dvec3& world) const;
    /// The gradient of the signed field at a world point, in world units: central differences of
    /// the trilinear field half a voxel either side, taken to world space by the transform's
    /// inverse transpose Jacobian. It points outward for both classes; (0, 0, 0) where the field
    /// is flat (farther than the narrow band reaches from the surface).
    glm::dvec3 fieldGradient(const glm::dvec3& world) const;
    /// Whether the isosurface (where the trilinear field changes side) comes within `radius` index
    /// voxels of a world point, as far as samples show: the point's side against those of the
    /// points at half and the whole radius along 26 directions (to the faces, edges and corners of
    /// a cube). A flat surface within 0.88 of the radius always shows; a speck between the
    /// directions may not.
    bool surfaceWithin(const glm::dvec3& world, double radius) const;

    const Impl& impl() const { return *mImpl; }
    bool valid() const { return static_cast<bool>(mImpl); }

private:
    std::shared_ptr<const Impl> mImpl;
};

/// A grid's name as messages and tables show it: a file may name a grid with anything, megabytes
/// of it or control bytes that would drive the user's terminal, so a name longer than 100 bytes is
/// cut short (with "...") and bytes below a space are written as \xNN.
std::string printableName(const std::string& name);

/// Lists the grids of a .vdb file without reading their voxels.
/// @throw Error if the file is missing, unreadable or not a VDB file.
std::vector<GridSummary> listGrids(const std::string& path);

/// Reads one scalar grid of a .vdb file (half-float and Blosc storage included) and checks that it
/// can be meshed: finite values, a background outside the object, an isovalue that crosses it.
/// @throw Error naming the file, the grid and what to do, for each of those problems.
Volume readVolume(const std::string& path, const VolumeOptions& options = {});

/// A dense block of voxel values held by an embedding program (a numpy array, an image stack).
/// The values are read, not kept: the caller may free them once volumeFromDense returns.
struct DenseVolume {
    const float* values = nullptr; // dims.x * dims.y * dims.z values in C order (the last index
                                   // varies fastest): values[(i * dims.y + j) * dims.z + k] is
                                   // voxel (i, j, k), as numpy's array[i, j, k]
    glm::ivec3 dims{0};
    glm::dmat4 indexToWorld{1.0};                    // world = indexToWorld * (i, j, k, 1), column vectors (glm's and
                                                     // nibabel's convention); last row (0, 0, 0, 1), invertible
    VolumeClass volumeClass = VolumeClass::LevelSet; // the values' meaning: a dense array carries
                                                     // no class, so the caller names it
};

/// Builds a sparse grid from a dense block and checks it as readVolume does. The background, the
/// value outside the object, is the largest value for a level set and the smallest for a fog
/// volume (0 for a 0..1 density, -1000 for CT); voxels equal to it are inactive, so a level set's
/// default isovalue is 0 and a fog volume's is halfway from the background to the densest value,
/// as for a .vdb file. `source` names the volume in messages and reports; options.gridName names
/// the grid.
/// @throw UsageError if dims are not positive, values is null, or the matrix is not an invertible
///        affine map; Error for what readVolume refuses (NaN values, an isovalue crossing nothing).
Volume volumeFromDense(const DenseVolume& dense, const VolumeOptions& options, const std::string& source);

/// Writes the volume's grid to a .vdb file, an OutputSet of one file: a failure never leaves half a
/// file, and the file that was there stays as it was.
/// @throw Error if the file cannot be written (OutputSet).
void writeVolume(const Volume& volume, const std::string& path);

const char* toString(VolumeClass volumeClass);

} // namespace pipetile
