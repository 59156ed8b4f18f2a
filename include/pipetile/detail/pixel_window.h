// pipetile — internal (namespace detail, not part of the API): the pixels a slice plane has read,
// for the boundary walk (contour.cpp) to read in place instead of one value() call per pixel.
#pragma once

#include <pipetile/slicer.h>

#include <glm/vec2.hpp>

namespace pipetile::detail {

/// The pixels SlicePlane::eastCracks() read, row-major from `min` (values[(v - min.y) * width +
/// u - min.x] is plane.value(u, v)); null `values` before eastCracks() or where the plane's leaves
/// lie too far apart for one image. Valid while the plane lives and until its next eastCracks().
struct PixelWindow {
    const double* values = nullptr;
    glm::ivec2 min{0};
    int width = 0, height = 0;
};

} // namespace pipetile::detail
