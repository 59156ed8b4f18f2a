// pipetile — volume, OpenVDB side: build a Volume from a grid in memory, and reach its grid.
// Only translation units that really need OpenVDB types include this header.
#pragma once

#include <pipetile/volume.h>

#include <openvdb/openvdb.h>

namespace pipetile {

struct Volume::Impl {
    openvdb::FloatGrid::ConstPtr grid; // active tiles voxelized, so every boundary lies in a leaf
    std::string source;
    std::string gridName;
    VolumeClass volumeClass = VolumeClass::LevelSet;
    double iso = 0.0;
    double minValue = 0.0, maxValue = 0.0;
    long long insideVoxels = 0; // active voxels inside the surface at iso
    long long hotVoxels = 0;    // active voxels the default fog isovalue left out (Volume::hotVoxels)
    openvdb::CoordBBox bbox;    // active voxels
};

/// Wraps a grid already in memory (an embedding pipeline's, or a generated sample) and runs the
/// same checks as readVolume. `source` names it in messages and reports.
/// @throw Error if the grid is empty, holds NaN or infinite values, or the isovalue crosses nothing.
Volume volumeFromGrid(openvdb::FloatGrid::ConstPtr grid, const VolumeOptions& options, const std::string& source);

/// The grid behind a volume (shared, not copied).
inline const openvdb::FloatGrid& gridOf(const Volume& volume)
{
    return *volume.impl().grid;
}

} // namespace pipetile
