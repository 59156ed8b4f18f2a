// pipetile — sample volumes with known geometry (phantoms).
//
// Each sample is a narrow-band level set (half-width 3 voxels, background 3 voxels, class level
// set) generated from an analytic signed distance function, so tests can compare meshes against
// exact geometry. World units equal voxels (voxel size 1) unless a sample says otherwise.
#pragma once

#include <pipetile/volume.h>

#include <glm/vec3.hpp>

#include <functional>
#include <string>
#include <vector>

namespace pipetile::samples {

/// Signed distance in world units, negative inside.
using DistanceFunction = std::function<double(const glm::dvec3& world)>;

struct SampleInfo {
    std::string name;        // "phantom", "straight", ..., "oblique": see sampleList()
    std::string description; // one line for `pipetile sample --list`
    glm::ivec3 dims{0};      // grid dimensions in voxels, index space [0, dims)
    double voxelSize = 1.0;  // world units per voxel
    // Known topology of the sample's isosurface (volumeToMesh at the level set's zero), each
    // sample's comment in phantoms.cpp says why: the Euler characteristic V - E + F, summed over
    // the closed surfaces (2 - 2 genus each), and the number of those surfaces (an inward-facing
    // void counts as one).
    int euler = 0;
    int components = 0;
};

/// All samples, in a fixed order; "phantom" first (it is the default input of `pipetile mesh`).
const std::vector<SampleInfo>& sampleList();

/// The analytic signed distance of a sample. Exact outside the object; inside it is exact or a
/// close approximation, as each sample's comment in phantoms.cpp says.
/// @throw Error if there is no sample of that name (the message lists the names).
DistanceFunction sampleDistance(const std::string& name);

/// Generates the sample's level set. Deterministic: the same name always gives the same voxels.
/// @throw Error if there is no sample of that name.
Volume makeSample(const std::string& name);

/// Exact signed distance to the capsule of radius `radius` around the segment [a, b].
double capsuleDistance(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, double radius);

/// Generates a narrow-band level set of any signed distance function on [0, dims) voxels.
/// Only the 8^3 blocks whose centre lies within reach of the band are evaluated.
Volume levelSetFromDistance(const DistanceFunction& distance, const glm::ivec3& dims, double voxelSize,
                            const std::string& source);

} // namespace pipetile::samples
