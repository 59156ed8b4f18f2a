// pipetile — mesh: the triangle and triangle-mesh types every stage hands on (tiler, caps,
// multires, mesh_io, validate). Plain data with no invariants enforced: a reader of a mesh checks
// what it relies on (writeMesh rejects ids out of range; validateMesh reports them).
#pragma once

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace pipetile {

/// Three vertex ids, counterclockwise seen from outside.
using Triangle = std::array<std::uint32_t, 3>;

/// A triangle mesh in world space, triangles counterclockwise seen from outside.
struct TriangleMesh {
    std::vector<glm::dvec3> vertices; // world units (the grid's transform applied)
    std::vector<Triangle> triangles;  // ids into `vertices`
};

} // namespace pipetile
