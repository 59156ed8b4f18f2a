// pipetile — tiler: the triangle band between two corresponding contours, and end caps.
//
// Integer-only: a band is computed from the contours' edge-type strings alone, never from
// coordinates (paper §4; DESIGN.md, Integer-only claim). src/tiler.cpp is compiled without
// floating-point registers on x86-64 to prove it. Only what is marked @throw throws (besides
// std::bad_alloc).
#pragma once

#include <pipetile/contour.h>
#include <pipetile/contour_tree.h>
#include <pipetile/mesh.h>

#include <cstdint>
#include <vector>

namespace pipetile {

/// Tiles the band between contour A (slice k, m crossings) and contour B (slice k+1, n crossings)
/// by traversing their contour trees together (paper §4.2): level-1 nodes x meet, so their F
/// edges make a quad (two triangles, split along the same diagonal everywhere); excursions of the
/// same type meet child by child (traversal cases 1 and 2); a child, or a whole excursion, with
/// no partner is fanned to the other contour's vertex where the traversal stands (case 3).
/// Two excursions of one sector that reach the same rays but parse differently (a ray grazing a
/// wall clips a bulge on one contour only) are paired along their rays instead: the strip whose
/// spanning edges skip the fewest rays, ties going the traversal's way. Still integers only.
/// Both contours wind counterclockwise seen from +w. Vertex ids: A's crossing i is i, B's
/// crossing j is m + j.
///
/// Always returns exactly m + n triangles forming a closed strip: every contour edge lies in one
/// triangle, and consecutive triangles share a spanning edge (an acceptable surface). The result
/// does not depend on which crossing each contour lists first.
std::vector<Triangle> tileBand(const ContourTree& a, const ContourTree& b);

/// The same for contours given by their edge strings alone, crossing 0 on ray 0 (tests, tools).
/// @throw UsageError if a string is empty or does not wind once around its centre (#F - #B
///        must be positive: the ray count).
std::vector<Triangle> tileBand(const std::vector<EdgeType>& a, const std::vector<EdgeType>& b);

/// The integer description of a contour given by its edge string, crossing 0 on ray 0: rays from
/// the F and B edges, every depth 0.
ContourString stringOfEdges(const std::vector<EdgeType>& edges);

/// Closes a contour of m crossings (ids 0..m-1) with a fan around an apex (id m): m triangles.
/// `top` caps the last contour of a tube (normals toward +w); otherwise the first (toward -w).
std::vector<Triangle> tileCap(std::uint32_t m, bool top);

/// Closes a contour of m >= 3 crossings without an apex: a fan from crossing 0, m - 2 triangles
/// (none for m < 3).
/// For caps whose apex was not found beyond the last slice (a tube ending inside another).
std::vector<Triangle> tileFlatCap(std::uint32_t m, bool top);

} // namespace pipetile
