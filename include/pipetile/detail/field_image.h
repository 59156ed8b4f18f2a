// pipetile — internal (namespace detail, not part of the API): a signed field on a small pixel
// image, and the contour functions that read one, for hand-made contours in tests and fuzzing.
// The library itself reads slice planes (slicer.h); these take the same code paths.
#pragma once

#include <pipetile/contour.h>

#include <glm/vec2.hpp>

#include <vector>

namespace pipetile::detail {

/// A signed field on a small pixel image (negative inside). Pixels outside the image read as +1
/// (outside).
struct FieldImage {
    glm::ivec2 origin{0}; // (u, v) of the first pixel
    int width = 0, height = 0;
    std::vector<double> values; // row-major, width * height

    double value(int u, int v) const;
    bool inside(int u, int v) const { return value(u, v) < 0.0; }
    double sample(const glm::dvec2& uv) const;       // bilinear
    void cell(int u, int v, double values[4]) const; // (u, v), (u + 1, v), (u, v + 1), (u + 1, v + 1)
};

/// traceBoundaries, castRays and refineContour of contour.h, on an image instead of a plane.
std::vector<BoundaryLoop> traceBoundaries(const FieldImage& image);
Contour castRays(const BoundaryLoop& loop, const glm::dvec2& center, const RaySet& rays, const FieldImage& image);
Contour refineContour(const Contour& coarse, const BoundaryLoop& loop, const FieldImage& image);
Contour refineContour(const Contour& coarse, const BoundaryLoop& loop, const RaySet& rays, const FieldImage& image);

} // namespace pipetile::detail
