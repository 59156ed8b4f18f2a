// pipetile — toroidal: baseline tilers that search the toroidal graph of two contours by geometry,
// for comparison with the integer-only contour-tree tiler (tiler.h; DESIGN.md, Measuring).
//
// Vertex (i, j) of the toroidal graph is the spanning edge a_i - b_j; an arc advances one contour
// by one point and adds one triangle. An acceptable surface is a cycle that goes once around in
// both directions: m + n triangles forming a closed strip, the same contract as tileBand.
#pragma once

#include <pipetile/tiler.h>

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pipetile {

/// What a toroidal tiler reports about one call.
struct ToroidalStats {
    std::size_t bytes = 0; // heap bytes of the tiler's working structures (choice bits, cost rows,
                           // kept paths) plus the triangles it returns; capacities, not sizes
};

/// Fuchs, Kedem & Uselton 1977: the acceptable surface of minimum total triangle area between the
/// closed contours A (slice k) and B (slice k+1, above A along +w), both counterclockwise seen
/// from +w. Exact over all cyclic alignments: every start on the smaller contour is searched, with
/// the start on the larger one fixed, by divide and conquer over non-crossing minimal paths
/// (O(mn log min(m, n)) time, one choice bit per graph vertex plus O(m + n log min(m, n)) words).
/// Ties are broken deterministically, but which of several equal-area surfaces wins may depend on
/// the inputs' start indices.
///
/// @param a [in] m world-space points of contour A; A's point i has vertex id i
/// @param b [in] n world-space points of contour B; B's point j has vertex id m + j
/// @param stats [out] optional; receives the working memory of this call
/// @return exactly m + n triangles in strip order, counterclockwise seen from outside: advancing
///         A from a_i with b_j adds {a_i, a_{i+1}, b_j}, advancing B adds {a_i, b_{j+1}, b_j}
/// @throw Error if a contour has fewer than 3 points or a point that is not finite
std::vector<Triangle> tileOptimal(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                  ToroidalStats* stats = nullptr);

/// tileOptimal's least area, with ties broken by the spans: each triangle also costs kSpanWeight
/// times the squared length of one of its spanning edges, so the surface's spans count once each.
/// Area cannot tell apart the tilings of two nearly equal contours a fraction of a voxel apart
/// (every strip between two parallel lines has the same area), and the least-area one fanned
/// points over chords up to 25 voxels away (a capsule tree's trunk, in slabs an eighth of a voxel
/// thick: aspect ratios to 7600). With the spans, each point joins the other contour's points
/// nearest it there; where the contours differ, area still decides (Gaffer's smoke's validated
/// runs stay as far from the isosurface as by area alone, where spans alone put its top level 0.06
/// voxel farther on average). Parameters, result, ids and throws as tileOptimal.
std::vector<Triangle> tileLeastAreaNearest(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                           ToroidalStats* stats = nullptr);
constexpr double kSpanWeight = 0.01;

/// Christiansen & Sederberg 1978: starts at A's point 0 and the point of B nearest to it, then at
/// each step advances the contour whose new spanning edge is shorter (A on a tie), until both
/// have gone once around. O(m + n) time; no working memory beyond the result. The contours are
/// not normalised to a common box first (C&S do that for unequal sections; pipe slices are alike).
///
/// Parameters, result and ids as tileOptimal.
/// @throw Error if a contour has fewer than 3 points or a point that is not finite
std::vector<Triangle> tileGreedy(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                                 ToroidalStats* stats = nullptr);

/// An acceptable surface between contours of m and n points (ids 0..m-1 and m..m+n-1, in strip
/// order, as tileOptimal returns it) in which one point is joined to every point of the other
/// contour repeats a spanning edge, in four triangles: a valid path on the toroidal graph, but
/// not a manifold. That is the only way a strip repeats an edge (a path revisits a node of the
/// torus only by going once around in one direction alone), so moving the run's last step past
/// the next step of the other contour removes it, and nothing else changes.
std::vector<Triangle> withoutFullFans(const std::vector<Triangle>& strip, std::uint32_t m, std::uint32_t n);

} // namespace pipetile
