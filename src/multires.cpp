// pipetile — multires: levels of detail, from a volume to closed triangle meshes.

#include <pipetile/caps.h>
#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/quality.h>
#include <pipetile/toroidal.h>
#include <pipetile/validate.h>

#include "reconstruction_state.h"

#include <glm/geometric.hpp>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace pipetile {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

double secondsSince(Clock::time_point start)
{
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// Runs `run()`, and the parallel loops inside it, on `threads` threads (0: all cores).
template <class Run>
void onThreads(int threads, const Run& run)
{
    if (threads == 0) return run(); // the default arena: creating one per call costs more than small loops
    tbb::task_arena arena(threads);
    arena.execute(run);
}

// Runs `body(i)` for i in [0, count) on `threads` threads (0: all cores). Each index writes only
// its own results, so the output never depends on the thread count.
template <class Body>
void forEachIndex(int threads, std::size_t count, const Body& body)
{
    onThreads(threads, [&] { tbb::parallel_for(std::size_t(0), count, [&](std::size_t i) { body(i); }); });
}

// Rule [1']: in each ambiguous sector, rank the F edges of `contour` by their distance to the F
// edge the neighbouring contour's tree stores for that sector (both lie in the same (u, v)
// plane coordinates). The only floating point of the correspondence, kept out of the integer
// translation units.
std::vector<std::vector<int>> rankAgainstNeighbour(const Contour& contour, const ContourString& string,
                                                   const Contour& neighbour, const ContourTree& neighbourTree)
{
    const std::vector<std::vector<int>> candidates = ContourTree::forwardEdges(string);
    bool ambiguous = false;
    for (const std::vector<int>& f : candidates) ambiguous = ambiguous || f.size() > 1;
    if (!ambiguous) return {};
    auto midpoint = [](const Contour& c, int edge) {
        return 0.5 * (c.crossings[edge].point + c.crossings[(edge + 1) % c.crossings.size()].point);
    };
    std::vector<std::vector<int>> rank(candidates.size());
    for (std::size_t x = 0; x < candidates.size(); ++x) {
        const glm::dvec2 target = midpoint(neighbour, neighbourTree.mainEdge(static_cast<int>(x)));
        std::vector<std::pair<double, int>> byDistance;
        for (std::size_t k = 0; k < candidates[x].size(); ++k) {
            const glm::dvec2 d = midpoint(contour, candidates[x][k]) - target;
            byDistance.push_back({d.x * d.x + d.y * d.y, static_cast<int>(k)});
        }
        std::stable_sort(byDistance.begin(), byDistance.end());
        rank[x].assign(candidates[x].size(), 0);
        for (std::size_t r = 0; r < byDistance.size(); ++r) rank[x][byDistance[r].second] = static_cast<int>(r);
    }
    return rank;
}

// Pixels past the other contour's point nearest it that a band's spanning edge may reach before the
// band goes to the least-area tiler (outOfRegister). Once 3 pixels, as for end bands (caps.cpp);
// since that tiler pairs nearest points where area cannot tell tilings apart
// (tileLeastAreaNearest), 2: the smoke's top level went from 1.01 to 0.78 voxels off (13 of its 31
// validated runs more than a voxel off to 12), with 3 fewer needles over 100 among the
// evaluation's 944 levels. 1.5 brought two more runs within a voxel, for 8 more needles (one of
// aspect 679 on a crop's top level).
constexpr double kBandOutOfRegister = 2.0;
// Pixels a section's centroid can move per voxel along the axis while the tube travels: a slope
// of 16, a wall within 3.6 degrees of the slicing plane (followedCentre).
constexpr double kSteepestTravel = 16.0;

// Where `p` lies along segment ab: 0 at a, 1 at b.
double placeOn(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& p)
{
    const glm::dvec2 ab = b - a;
    const double length2 = glm::dot(ab, ab);
    return length2 > 0.0 ? glm::dot(p - a, ab) / length2 : 0.0;
}

// Replaces the triangle on edge u-v by a fan through `between` (vertices that lie on that edge,
// in order from u to v), keeping its orientation: every other edge stays in the same triangles.
void splitEdge(std::vector<Triangle>& triangles, std::uint32_t u, std::uint32_t v,
               const std::vector<std::uint32_t>& between)
{
    for (std::size_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = triangles[t][k], b = triangles[t][(k + 1) % 3], c = triangles[t][(k + 2) % 3];
            if (!((a == u && b == v) || (a == v && b == u))) continue;
            std::vector<std::uint32_t> chain{a};
            if (a == u)
                chain.insert(chain.end(), between.begin(), between.end());
            else
                chain.insert(chain.end(), between.rbegin(), between.rend());
            chain.push_back(b);
            triangles[t] = {chain[0], chain[1], c};
            for (std::size_t i = 1; i + 1 < chain.size(); ++i) triangles.push_back({chain[i], chain[i + 1], c});
            return;
        }
    PIPETILE_ASSERT(false, "a contour edge lies in no triangle of its band");
}

// A position's bits: levels nest bit for bit, so vertices are found by them.
using PositionKey = std::array<std::uint64_t, 3>;

PositionKey positionKey(const glm::dvec3& p)
{
    PositionKey key;
    std::memcpy(key.data(), &p[0], sizeof key);
    return key;
}

std::vector<PositionKey> sortedKeys(const std::vector<glm::dvec3>& points)
{
    std::vector<PositionKey> keys(points.size());
    std::transform(points.begin(), points.end(), keys.begin(), positionKey);
    std::sort(keys.begin(), keys.end());
    return keys;
}

// For each vertex of `coarse`, a vertex of `fine` at the same position, bit for bit; each vertex of
// `fine` is taken once, duplicates in order. Sorting by the coordinates' bits finds them.
std::vector<std::uint32_t> matchVertices(const std::vector<glm::dvec3>& coarse, const std::vector<glm::dvec3>& fine,
                                         int level)
{
    using Key = PositionKey;
    std::vector<std::pair<Key, std::uint32_t>> sorted(fine.size());
    for (std::size_t v = 0; v < fine.size(); ++v) sorted[v] = {positionKey(fine[v]), static_cast<std::uint32_t>(v)};
    std::sort(sorted.begin(), sorted.end());
    std::vector<bool> taken(sorted.size(), false);
    std::vector<std::uint32_t> match(coarse.size());
    for (std::size_t v = 0; v < coarse.size(); ++v) {
        const Key key = positionKey(coarse[v]);
        auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(key, std::uint32_t(0)));
        while (it != sorted.end() && it->first == key && taken[it - sorted.begin()]) ++it;
        if (it == sorted.end() || it->first != key)
            throw InternalError("internal invariant broken: vertex " + std::to_string(v) + " of level " +
                                std::to_string(level) + " is not a vertex of level " + std::to_string(level + 1));
        taken[it - sorted.begin()] = true;
        match[v] = it->second;
    }
    return match;
}

} // namespace

NestedLevels nestLevels(const std::vector<LevelMesh>& levels)
{
    NestedLevels nested;
    if (levels.empty()) return nested;
    const std::vector<glm::dvec3>& finest = levels.back().mesh.vertices;
    // toFinest[L][v]: level L's vertex v in the finest level, composed down the levels.
    std::vector<std::vector<std::uint32_t>> toFinest(levels.size());
    toFinest.back().resize(finest.size());
    for (std::size_t v = 0; v < finest.size(); ++v) toFinest.back()[v] = static_cast<std::uint32_t>(v);
    for (std::size_t L = levels.size() - 1; L-- > 0;) {
        const std::vector<std::uint32_t> match =
            matchVertices(levels[L].mesh.vertices, levels[L + 1].mesh.vertices, static_cast<int>(L));
        toFinest[L].resize(match.size());
        for (std::size_t v = 0; v < match.size(); ++v) toFinest[L][v] = toFinest[L + 1][match[v]];
    }
    // Coarse-first: level 0's vertices in its own order, then what each level adds, in its order.
    constexpr std::uint32_t kUnset = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> newId(finest.size(), kUnset);
    nested.vertices.reserve(finest.size());
    for (std::size_t L = 0; L < levels.size(); ++L) {
        for (std::uint32_t f : toFinest[L])
            if (newId[f] == kUnset) {
                newId[f] = static_cast<std::uint32_t>(nested.vertices.size());
                nested.vertices.push_back(finest[f]);
            }
        nested.vertexCounts.push_back(nested.vertices.size());
        std::vector<Triangle> triangles = levels[L].mesh.triangles;
        for (Triangle& t : triangles)
            for (std::uint32_t& v : t) v = newId[toFinest[L][v]];
        nested.triangles.push_back(std::move(triangles));
    }
    return nested;
}

void checkMeshOptions(const MeshOptions& options)
{
    if (options.baseRays < 3 || options.baseRays > 4096)
        throw UsageError("the base rays must be between 3 and 4096 (got " + std::to_string(options.baseRays) +
                             "); with fewer than 3 rays forward and backward edges cannot be told apart",
                         {Setting::Rays});
    if (options.levels < 1 || options.levels > 16)
        throw UsageError("the levels must be between 1 and 16 (got " + std::to_string(options.levels) + ")",
                         {Setting::Levels});
    const long long finest = static_cast<long long>(options.baseRays) << (options.levels - 1);
    if (finest > 65536)
        throw UsageError(std::to_string(options.baseRays) + " base rays with " + std::to_string(options.levels) +
                             " levels ask for " + std::to_string(finest) +
                             " rays per contour at the top level; the limit is 65536: lower the rays or the levels",
                         {Setting::Rays, Setting::Levels});
    if (!(options.minContourArea >= 0.0) || !std::isfinite(options.minContourArea))
        throw UsageError("the minimum contour area must be a finite number >= 0");
    if (options.threads < 0) throw UsageError("the threads must be 0 (all cores) or more", {Setting::Threads});
}

Reconstruction::Reconstruction(const Volume& volume, const MeshOptions& options)
    : Reconstruction(volume, options, StrayingPieces{})
{
    // A fork's or merge's part in a slab half a voxel thick can fan a contour's loop to a few
    // points of the single contour voxels away (a crop of the smoke at iso 0.2: a loop 7 pixels
    // across, 1.50 voxels off at the top level), and a band between contours of different shapes
    // one vertex to an arc (a contour that grows by 4.6 pixels in a voxel: 1.45). The top level's
    // junctions and bands that may fan are tiled once here, and where any strays more than a
    // voxel from the isosurface, the skeleton is built again with those pieces from their cells.
    // Every level is built from the last skeleton alone.
    //
    // The planes the second build adds to halve a straying junction's slab (thinJunctions) cut the
    // slabs around it anew, and a band there can fan where the first build's did not (a crop of the
    // smoke at iso 0.1: a wall's band from 38.25 to 38.5 kept to the surface; cut at 38.375, its
    // lower half fanned a vertex across a void, 1.84 voxels off). The second build's pieces in
    // those ranges are asked too, and a third build takes the first's pieces and theirs; its own
    // are not asked again, so that a mesh costs at most three skeletons.
    const Clock::time_point start = Clock::now();
    const double everywhere = std::numeric_limits<double>::infinity();
    StrayingPieces straying = strayingPieces({{-everywhere, everywhere}});
    double seconds = mStats.seconds + secondsSince(start); // the first build and its tiling
    if (!straying.empty()) {
        *this = Reconstruction(volume, options, straying);
        seconds += mStats.seconds;
    }
    if (!straying.thinJunctions.empty()) {
        const Clock::time_point asked = Clock::now();
        const bool grew = straying.add(strayingPieces(straying.thinJunctions));
        seconds += secondsSince(asked);
        if (grew) {
            *this = Reconstruction(volume, options, std::move(straying));
            seconds += mStats.seconds;
        }
    }
    mStats.seconds = seconds;
}

bool Reconstruction::StrayingPieces::add(const StrayingPieces& more)
{
    bool grew = false;
    for (const std::array<int, 3>& junction : more.junctions) grew |= junctions.insert(junction).second;
    for (const std::pair<int, int>& band : more.bands) grew |= bands.insert(band).second;
    for (const std::array<int, 3>& end : more.ends) grew |= ends.insert(end).second;
    for (const auto& [ranges, added] :
         {std::pair{&thinJunctions, &more.thinJunctions}, std::pair{&bandRanges, &more.bandRanges}})
        for (const std::pair<double, double>& range : *added)
            if (std::find(ranges->begin(), ranges->end(), range) == ranges->end()) {
                ranges->push_back(range);
                grew = true;
            }
    return grew;
}

Reconstruction::Reconstruction(const Volume& volume, const MeshOptions& options, StrayingPieces cellPieces)
    : mVolume(volume),
      mOptions(options),
      mCellPieces(std::move(cellPieces))
{
    const Clock::time_point start = Clock::now();
    checkMeshOptions(options);
    mPlan = planSlices(volume, options.slicing);
    traceSlices();
    correspond();
    resolveEvents();
    followCentres();
    centreParts();
    closeEnds();
    groupRays();
    chooseSlices();
    for (const Tube& tube : mTubes)
        for (const TubeEnd* end : {&tube.bottom, &tube.top}) {
            if (end->annulus >= 0 || end->joined()) continue;
            ++mStats.caps;
            mStats.flatCaps += end->hasApex ? 0 : 1;
            mStats.clippedCaps += end->fan ? 0 : 1;
        }
    mStats.tubes = static_cast<int>(mTubes.size());
    for (const std::vector<SliceLoop>& loops : mLoops)
        for (const SliceLoop& l : loops)
            mStats.longestBoundary = std::max(mStats.longestBoundary, static_cast<long long>(l.loop.corners.size()));
    // Never exhaust the machine: about 100 bytes per crossing of the finest level (vertex, edge
    // type, tree node, two triangles) while it is built and written.
    const double crossings = static_cast<double>(mStats.contours + mStats.endContours) *
                             static_cast<double>(static_cast<long long>(options.baseRays) << (options.levels - 1));
    constexpr double kBytesPerCrossing = 100.0, kBudget = 8.0 * 1024 * 1024 * 1024;
    if (crossings * kBytesPerCrossing > kBudget)
        throw UsageError(std::to_string(options.baseRays) + " base rays with " + std::to_string(options.levels) +
                             " levels would need about " +
                             std::to_string(static_cast<long long>(crossings * kBytesPerCrossing / (1 << 30))) +
                             " GiB for the finest level (" + std::to_string(mStats.contours) +
                             " contours); lower the levels",
                         {Setting::Levels});
    mStats.seconds = secondsSince(start);
}

std::vector<Reconstruction::SliceLoop> Reconstruction::traceContours(double w, SliceCounts& counts) const
{
    const SlicePlane plane(mVolume, mPlan, w);
    std::vector<SliceLoop> loops;
    for (BoundaryLoop& loop : traceBoundaries(plane)) {
        if (std::abs(loop.area) < mOptions.minContourArea) {
            ++counts.small;
            continue;
        }
        LoopView view = viewFrom(loop, centralPoint(loop));
        if (view.winding != 1) {
            ++counts.unwound;
            continue;
        }
        RadialProfile profile = radialProfile(view, profileDirections());
        loops.push_back({std::move(loop), std::move(view), std::move(profile)});
    }
    return loops;
}

int Reconstruction::profileDirections() const
{
    return static_cast<int>(std::min(static_cast<long long>(mOptions.baseRays) << (mOptions.levels - 1), 256LL));
}

void Reconstruction::traceSlices()
{
    const std::size_t sliceCount = mPlan.positions.size();
    mStats.slices = static_cast<int>(sliceCount);
    mPositions = mPlan.positions;
    std::vector<SliceCounts> counts(sliceCount);
    mLoops.assign(sliceCount, {});
    forEachIndex(mOptions.threads, sliceCount,
                 [&](std::size_t s) { mLoops[s] = traceContours(mPositions[s], counts[s]); });
    for (std::size_t s = 0; s < sliceCount; ++s) {
        mStats.droppedSmall += counts[s].small;
        mStats.droppedUnwound += counts[s].unwound;
        mStats.emptySlices += mLoops[s].empty() ? 1 : 0;
        for (const SliceLoop& l : mLoops[s]) {
            ++mStats.contours;
            mStats.holes += l.loop.hole() ? 1 : 0;
        }
    }
    if (mStats.contours == 0)
        throw Error("'" + mVolume.source() + "', grid '" + printableName(mVolume.gridName()) +
                        "': no slice crosses the surface at iso " + std::to_string(mVolume.iso()) + " (" +
                        std::to_string(sliceCount) +
                        " slices); the object is thinner than the slice spacing: lower the spacing",
                    {Setting::Spacing});
}

void Reconstruction::centreParts(std::size_t first)
{
    // A part is cast with its partner's rays from the partner's central point, so that ray k of
    // both meets the same side of the branch; the part must run counterclockwise and wind once
    // around that point. Where the point lies less than a quarter pixel inside the partner and
    // its parts (a sliver where a branch barely touches the slab, a ring's sector against the
    // piece of wall it joins, a branch leaving so obliquely that its centre lies outside its
    // part), the partner moves to the point deepest inside them all, if that is deeper. A part's
    // crossings lie on its polygon (no root finding), so any point inside serves it; a quarter
    // pixel keeps the partner's own rays from grazing its boundary where there is room. A part
    // still not wound once around the centre is tiled by the minimum-area tiler (assemble).
    constexpr double kClearance = 0.25;
    std::map<std::pair<int, int>, std::vector<Junction::Part*>> partsOf;
    for (std::size_t j = first; j < mJunctions.size(); ++j)
        for (std::size_t k = 0; k < mJunctions[j].many.size(); ++k)
            partsOf[mJunctions[j].many[k]].push_back(&mJunctions[j].parts[k]);
    for (const auto& [loop, parts] : partsOf) {
        SliceLoop& partner = mLoops[loop.first][loop.second];
        std::vector<Junction::Part*> counterclockwise; // the others wind around no point
        std::vector<const std::vector<glm::dvec2>*> polygons;
        for (Junction::Part* part : parts)
            if (polygonArea(part->polygon) > 0.0) {
                counterclockwise.push_back(part);
                polygons.push_back(&part->polygon);
            }
        const double depth = commonDepth(partner.loop, polygons, partner.view.center);
        glm::dvec2 centre;
        if (!polygons.empty() && depth < kClearance && deepestCommonPoint(partner.loop, polygons, centre) > depth) {
            LoopView view = viewFrom(partner.loop, centre);
            if (view.winding == 1) {
                partner.profile = radialProfile(view, profileDirections());
                partner.view = std::move(view);
            }
        }
        for (Junction::Part* part : counterclockwise) {
            LoopView view = viewOfPolygon(part->polygon, partner.view.center);
            if (view.winding != 1) continue;
            part->view = std::move(view);
            part->view.hole = partner.loop.hole();
        }
    }
}

void Reconstruction::followCentres()
{
    // Rays pair by index from each section's own central point, so a band is only as good as the
    // agreement of its two centres. Along a tube, each centre follows its predecessor's, moved as
    // the section moves: by the centroid's shift where that keeps more of the shape in register
    // (a tube that travels), not at all where standing still keeps more (a tube that grows an arm:
    // the T's side branch pulls the centroid 8 voxels along it at its first section while the
    // trunk stays put, and rays from there crossed the trunk's band 2.7 voxels inside it).
    // Where that point is not clear of the boundary (a C's centroid in its gap, a crescent's by
    // its inner edge), the centre stays near it all the same: at the nearest pixel two pixels
    // deep. Taking the ridge pixel where the tie falls by scan order put consecutive centres
    // across the C from each other, and their bands crossed its gap.
    // Where a centre cannot follow a track that hugged its boundary (a dumbbell's centroid less
    // than a pixel from its neck, then outside it, and the clear pixel nearest in one of the
    // bells), or whose part of the section is gone from the next one (an arm of a fused tree's
    // section, a branch lying along the plane, whose top takes it away within an eighth of a
    // voxel: centres 13 pixels apart, 3.56 voxels off, 1.68 now), the centres before it may follow
    // it back (followBack), kept where the bands are in better register. So may they wherever the
    // jump lands on the section's centroid: a crop of the aorta sliced along x, whose
    // track came within a pixel of the next section's boundary, jumped 3.5 pixels to it, and the
    // band between two nearly equal contours twisted across a corner, 1.07 voxels off (0.79 now;
    // the thin oblique tube sliced along z from 0.54 to 0.42). A C's or a crescent's clear pixels
    // lie two pixels deep and turn with it: their tracks stay (the hollow Y's wall by its open
    // rim, followed back from such jumps, was 2.5 voxels off at level 1, against 0.97; followed
    // back from every jump, 1.70).
    for (const Tube& tube : mTubes)
        for (std::size_t k = 1; k < tube.members.size(); ++k) {
            bool followed = true;
            const SliceLoop& before = memberLoop(tube, k - 1);
            SliceLoop& loop = memberLoop(tube, k);
            const bool hugged = !clearOfPolygon(before.loop.points, before.view.center, 1.0);
            const bool gone = !liesInside(loop.loop, before.view.center);
            followCentre(before, loop, followed, spacingBetween(tube, k - 1, k));
            if (!followed && (hugged || gone || loop.view.center == loop.loop.centroid)) followBack(tube, k);
        }
}

void Reconstruction::followBack(const Tube& tube, std::size_t k)
{
    // Bands pair rays from both ends' centres, so a jump between two of them misregisters a band
    // however thin: a random tree's neck before a fork had centres 2 pixels apart in planes an
    // eighth of a voxel apart, and triangles across a bell 1.5 voxels off. The centres before
    // member k follow its own back, as far as each can follow; the new track is kept where its
    // bands are in better register in all (summed misregistration) than the old one's; else the
    // jump stays (the hollow Y's, by its open rim: 5.14 pixels in all against 4.84).
    std::vector<std::pair<LoopView, RadialProfile>> old;
    std::size_t j = k;
    while (j > 0) {
        SliceLoop& loop = memberLoop(tube, j - 1);
        std::pair<LoopView, RadialProfile> kept{loop.view, loop.profile};
        bool followed = true;
        if (!followCentre(memberLoop(tube, j), loop, followed, spacingBetween(tube, j - 1, j), true)) break;
        old.push_back(std::move(kept));
        --j;
    }
    if (old.empty()) return;
    // Members j .. k-1 moved: the bands from member max(j, 1) - 1 up to member k changed.
    const auto bandsOff = [&] {
        double sum = 0.0;
        for (std::size_t i = std::max<std::size_t>(j, 1); i <= k; ++i) {
            const SliceLoop &a = memberLoop(tube, i - 1), &b = memberLoop(tube, i);
            sum += misregistration(a.view, a.profile, b.view, b.profile);
        }
        return sum;
    };
    const auto swapTracks = [&] {
        for (std::size_t i = 0; i < old.size(); ++i) {
            SliceLoop& loop = memberLoop(tube, k - 1 - i);
            std::swap(loop.view, old[i].first);
            std::swap(loop.profile, old[i].second);
        }
    };
    const double followedOff = bandsOff();
    swapTracks();
    if (followedOff < bandsOff()) swapTracks();
}

Reconstruction::SliceLoop& Reconstruction::memberLoop(const Tube& tube, std::size_t k)
{
    return mLoops[tube.members[k].first][tube.members[k].second];
}

double Reconstruction::spacingBetween(const Tube& tube, std::size_t i, std::size_t k) const
{
    return std::abs(mPositions[tube.members[k].first] - mPositions[tube.members[i].first]);
}

bool Reconstruction::followCentre(const SliceLoop& from, SliceLoop& loop, bool& followed, double spacing,
                                  bool onlyFollowed) const
{
    const glm::dvec2 centre = followedCentre(from, loop, &followed, spacing);
    if (centre == loop.view.center || (onlyFollowed && !followed)) return false;
    LoopView view = viewFrom(loop.loop, centre);
    if (view.winding != 1) return false;
    loop.profile = radialProfile(view, profileDirections());
    loop.view = std::move(view);
    return true;
}

glm::dvec2 Reconstruction::followedCentre(const SliceLoop& before, const SliceLoop& loop, bool* followed,
                                          double spacing)
{
    const glm::dvec2 shift = loop.loop.centroid - before.loop.centroid;
    const glm::ivec2 step(glm::round(shift));
    const glm::dvec2 travelled = loop.loop.centroid + (before.view.center - before.loop.centroid);
    // A shift under a quarter of the section's radius turns its band by at most about 14
    // degrees either way: only larger ones are worth telling apart, pixel by pixel.
    const double radius = std::sqrt(std::abs(loop.loop.area) / kPi);
    const bool travels =
        !sectionChanged(before, loop, travelled, spacing) &&
        (glm::length(shift) < 0.25 * radius || step == glm::ivec2(0) ||
         overlapPixels(loop.loop, before.loop, step) >= overlapPixels(loop.loop, before.loop, glm::ivec2(0)));
    const glm::dvec2 candidate = travels ? travelled : before.view.center;
    // A followed centre must stay clear of the boundary (by a pixel, or as far as the centroid
    // is), or its rays would crowd one side of the section.
    const bool centroidIn = centroidInside(loop.loop);
    const bool centroidClear = centroidIn && clearOfPolygon(loop.loop.points, loop.loop.centroid, 1.0);
    const double clearance = centroidIn && !centroidClear ? boundaryClearance(loop.loop, loop.loop.centroid) : 1.0;
    const bool clear = liesInside(loop.loop, candidate) && clearOfPolygon(loop.loop.points, candidate, clearance);
    if (followed) *followed = clear;
    if (clear) return candidate;
    // Otherwise the clear pixel nearest where the centre would have gone, when that point still
    // lies inside a section wide enough for clear pixels to mean something: a tree's blob of
    // fused branches whose centre came within a pixel of its edge jumped to the centroid, 17
    // pixels away in another branch, and its band crossed the blob (5.1 voxels off at the top
    // level; 1.51 now). So too when it lies less than a pixel outside, where the section's edge
    // moved in past it: another blob's centre, two pixels deep by its edge, jumped 7 pixels to
    // the centroid there, and 23 triangles of the twisted band were more than a voxel off (5 now).
    // Else the centroid if it is a pixel clear (a thin oblique tube's sections, 3 pixels in
    // radius, whose nearest pixel lags the track: 0.76 voxels off against 0.54); if not (it lies
    // outside a C, or hugs the inner edge of a crescent at a pipe's open rim, where a jump to it
    // turned the crescent's tips against each other's rays, 1.13 voxels off), the clear pixel
    // nearest.
    const bool wide = radius >= 4.0;
    const bool near = liesInside(loop.loop, candidate) || boundaryClearance(loop.loop, candidate) < 1.0;
    if (!centroidClear || (wide && near)) return clearPixelNear(loop.loop, candidate);
    return loop.loop.centroid;
}

bool Reconstruction::sectionChanged(const SliceLoop& before, const SliceLoop& loop, const glm::dvec2& travelled,
                                    double spacing)
{
    // A centroid that moves more than kSteepestTravel pixels per voxel along the axis is no tube
    // travelling (its wall would lie within 3.6 degrees of the plane) but its section changing:
    // part of a fused tree's blob coming or going. Its centre stands, where that keeps it at
    // least as deep inside the new section as travelling would. A dense tree's centres travelled
    // 3.5 pixels with such a centroid between planes an eighth of a voxel apart, and rays of one
    // index met the boundary 5 rays apart (1.46 voxels off at the top level; 0.91 now). Where
    // standing leaves the centre nearer the wall, it travels: kept off-centre along a tube whose
    // blob came and went, a centre's rays grazed a branch lying in the plane, in triangles of
    // aspect 2057.
    if (spacing <= 0.0 || glm::length(loop.loop.centroid - before.loop.centroid) <= kSteepestTravel * spacing)
        return false;
    const auto depth = [&](const glm::dvec2& p) {
        return liesInside(loop.loop, p) ? boundaryClearance(loop.loop, p) : 0.0;
    };
    return depth(before.view.center) >= depth(travelled);
}

void Reconstruction::groupRays()
{
    // Ray groups: a tube, joined with the tubes an annulus ties it to (their end contours are
    // tiled together, so they must share their rays). Junctions tile by geometry and need none.
    std::vector<int> group(mTubes.size());
    for (std::size_t t = 0; t < mTubes.size(); ++t) group[t] = static_cast<int>(t);
    auto root = [&](int t) {
        while (group[t] != t) t = group[t] = group[group[t]];
        return t;
    };
    for (std::size_t t = 0; t < mTubes.size(); ++t)
        for (const TubeEnd* end : {&mTubes[t].bottom, &mTubes[t].top})
            if (end->annulus >= 0) group[root(end->annulus)] = root(static_cast<int>(t));
    for (std::size_t t = 0; t < mTubes.size(); ++t)
        for (const auto& [s, l] : mTubes[t].members) mLoops[s][l].group = root(static_cast<int>(t));
}

void Reconstruction::chooseSlices()
{
    for (const Tube& tube : mTubes)
        for (std::size_t k = 0; k < tube.members.size(); ++k) {
            const bool end = k == 0 || k + 1 == tube.members.size();
            mLoops[tube.members[k].first][tube.members[k].second].fromLevel = end || mOptions.everySlice ? 0 : kNever;
        }
    if (mOptions.everySlice) return;
    // Profiles along the finest level's directions (at most 256, to bound the cost: each halving
    // compares every member of a span in every direction), so that what a level skips does not
    // depend on its own rays. Each as in-plane points, centre + r * direction, nearest and farthest crossing per
    // direction: rays pair crossings of one direction from each slice's own centre, and so do
    // these.
    const int directions = profileDirections();
    struct Profile {
        std::vector<glm::dvec2> points; // per direction: nearest, farthest
        double radius = 0.0;            // the farthest crossing
    };
    std::vector<glm::dvec2> unit(directions);
    for (int d = 0; d < directions; ++d)
        unit[d] = {std::cos(2.0 * kPi * d / directions), std::sin(2.0 * kPi * d / directions)};
    std::vector<std::vector<Profile>> profiles(mLoops.size());
    forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
        profiles[s].resize(mLoops[s].size());
        for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
            const SliceLoop& loop = mLoops[s][l];
            if (loop.group < 0) continue;
            const RadialProfile& radial = loop.profile;
            Profile& profile = profiles[s][l];
            profile.points.resize(2 * directions);
            for (int d = 0; d < directions; ++d) {
                profile.points[2 * d] = loop.view.center + radial.nearest[d] * unit[d];
                profile.points[2 * d + 1] = loop.view.center + radial.farthest[d] * unit[d];
                profile.radius = std::max(profile.radius, radial.farthest[d]);
            }
        }
    });
    // The sagitta of each level's rays on a unit circle, 1 - cos(pi / n).
    std::vector<double> sagitta(mOptions.levels);
    for (int level = 0; level < mOptions.levels; ++level)
        sagitta[level] = 1.0 - std::cos(kPi / static_cast<double>(static_cast<long long>(mOptions.baseRays) << level));
    for (const Tube& tube : mTubes) {
        const auto profileOf = [&](std::size_t k) -> const Profile& {
            return profiles[tube.members[k].first][tube.members[k].second];
        };
        const auto wOf = [&](std::size_t k) { return mPositions[tube.members[k].first]; };
        // The coarsest level at which the span from member a to member b must keep its middle: the
        // first whose sagitta (on the larger of the two end loops) a member between them exceeds,
        // where it departs from the straight interpolation of a and b.
        const auto splitLevel = [&](std::size_t a, std::size_t b) {
            const Profile& pa = profileOf(a);
            const Profile& pb = profileOf(b);
            const double radius = std::max(pa.radius, pb.radius), coarsest = radius * sagitta[0];
            double worst = 0.0; // squared
            for (std::size_t j = a + 1; j < b; ++j) {
                const double t = (wOf(j) - wOf(a)) / (wOf(b) - wOf(a));
                const std::vector<glm::dvec2>& pj = profileOf(j).points;
                for (std::size_t i = 0; i < pj.size(); ++i) {
                    const glm::dvec2 miss = pj[i] - (pa.points[i] + t * (pb.points[i] - pa.points[i]));
                    worst = std::max(worst, miss.x * miss.x + miss.y * miss.y);
                }
                if (!(worst <= coarsest * coarsest))
                    return 0; // level 0 must split (NaN: a direction
                              // without crossing, too)
            }
            for (int level = 0; level < mOptions.levels; ++level)
                if (worst > radius * sagitta[level] * radius * sagitta[level]) return level;
            return kNever;
        };
        // Halving: a span that exists from level `from` keeps its middle member from the level
        // it must split at (not before the span exists); the halves then exist from there.
        const auto split = [&](const auto& self, std::size_t a, std::size_t b, int from) -> void {
            if (b - a < 2) return;
            const int level = std::max(from, splitLevel(a, b));
            if (level == kNever) return;
            const std::size_t middle = (a + b) / 2;
            mLoops[tube.members[middle].first][tube.members[middle].second].fromLevel = level;
            self(self, a, middle, level);
            self(self, middle, b, level);
        };
        split(split, 0, tube.members.size() - 1, 0);
    }
}

Skeleton Reconstruction::skeleton() const
{
    Skeleton skeleton;
    std::vector<std::vector<int>> segmentOf(mLoops.size());
    for (std::size_t s = 0; s < mLoops.size(); ++s) segmentOf[s].assign(mLoops[s].size(), -1);
    for (const Tube& tube : mTubes) {
        Skeleton::Segment segment;
        segment.hole = tube.hole;
        segment.wFirst = mPositions[tube.members.front().first];
        segment.wLast = mPositions[tube.members.back().first];
        segment.contours = static_cast<int>(tube.members.size());
        auto name = [](const TubeEnd& end) {
            return end.junction >= 0  ? "junction"
                   : end.patch >= 0   ? "patch"
                   : end.annulus >= 0 ? "rim"
                   : end.hasApex      ? "cap"
                                      : "flat cap";
        };
        segment.bottom = name(tube.bottom);
        segment.top = name(tube.top);
        segment.bottomJunction = tube.bottom.junction;
        segment.topJunction = tube.top.junction;
        for (const auto& [s, l] : tube.members) segmentOf[s][l] = static_cast<int>(skeleton.segments.size());
        skeleton.segments.push_back(segment);
    }
    for (const Junction& junction : mJunctions) {
        Skeleton::Junction j;
        j.kind = junction.kind;
        j.w = mPositions[junction.single.first];
        // The hub's plane, or the chords' middles' mean: where the saddle nodes got to.
        const std::size_t firstMiddle = junction.nodeOn.size();
        for (std::size_t node = firstMiddle; node < junction.nodeIndex.size(); ++node)
            j.crotchW +=
                junction.nodeIndex[node][mPlan.axis] / static_cast<double>(junction.nodeIndex.size() - firstMiddle);
        j.single = segmentOf[junction.single.first][junction.single.second];
        for (const auto& [s, l] : junction.many) j.partners.push_back(segmentOf[s][l]);
        skeleton.junctions.push_back(j);
    }
    for (const Patch& patch : mPatches) {
        int contours = 0;
        for (const Tube& tube : mTubes)
            for (const TubeEnd* end : {&tube.bottom, &tube.top})
                contours += end->patch == static_cast<int>(&patch - mPatches.data()) ? 1 : 0;
        // A face's patch reaches out to the empty plane past the grid's box (patchFace).
        const double wBelow = patch.below >= 0 ? mPositions[patch.below] : pastTheBox(mVolume, mPlan, false).w;
        const double wAbove = patch.above >= 0 ? mPositions[patch.above] : pastTheBox(mVolume, mPlan, true).w;
        skeleton.patches.push_back({wBelow, wAbove, contours, patch.surface.euler});
    }
    skeleton.unresolved = mUnresolved;
    return skeleton;
}

EulerProfile Reconstruction::cellProfile() const
{
    if (mCells) return *mCells;
    EulerProfile profile; // integer sums: the same for any thread count
    onThreads(mOptions.threads, [&] { profile = isosurfaceEulerProfile(mVolume, mPlan.axis); });
    return profile;
}

int Reconstruction::finestUsefulLevel() const
{
    for (int level = 0; level < mOptions.levels; ++level)
        if ((static_cast<long long>(mOptions.baseRays) << level) > mStats.longestBoundary)
            return std::max(level - 1, 0);
    return mOptions.levels - 1;
}

LevelMesh Reconstruction::buildLevel(int level) const
{
    if (level < 0 || level >= mOptions.levels)
        throw UsageError("level " + std::to_string(level) + " is outside 0.." + std::to_string(mOptions.levels - 1));
    // The level below decides which vertices must stay (collapseNeedleEdges); it is not timed.
    const std::vector<glm::dvec3> coarser = level > 0 ? buildLevel(level - 1).mesh.vertices : std::vector<glm::dvec3>{};
    const Clock::time_point start = Clock::now();
    const Contours contours = castLevel(level);
    const double casting = secondsSince(start);
    LevelMesh result = assemble(contours, level, coarser);
    result.castingSeconds = casting;
    result.seconds = secondsSince(start);
    return result;
}

Reconstruction::Contours Reconstruction::castLevel(int level) const
{
    const RaySet rays{mOptions.baseRays, level};
    Contours contours(mLoops.size());
    forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
        if (mLoops[s].empty()) return;
        const SlicePlane plane(mVolume, mPlan, mPositions[s]);
        for (const SliceLoop& l : mLoops[s])
            contours[s].push_back(l.fromLevel <= level ? cut(l, rays, plane) : Contour{});
    });
    addFoldRays(contours, level);
    return contours;
}

Reconstruction::Contours Reconstruction::refineContours(const Contours& coarse, int level) const
{
    // A contour the coarse level skipped is cast from scratch, with the rays its group's refined
    // contours get (they share them): the same contour as refining it would give. Every group has
    // coarse contours: tube ends are kept at every level.
    std::vector<const RaySet*> groupRays(mTubes.size(), nullptr); // group ids are tube indices
    for (std::size_t s = 0; s < mLoops.size(); ++s)
        for (std::size_t l = 0; l < mLoops[s].size(); ++l)
            if (mLoops[s][l].group >= 0 && !coarse[s][l].crossings.empty())
                groupRays[mLoops[s][l].group] = &coarse[s][l].rays;
    Contours contours(mLoops.size());
    forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
        if (mLoops[s].empty()) return;
        const SlicePlane plane(mVolume, mPlan, mPositions[s]);
        for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
            const SliceLoop& loop = mLoops[s][l];
            if (!coarse[s][l].crossings.empty())
                contours[s].push_back(refine(coarse[s][l], loop, coarse[s][l].rays.next(), plane));
            else if (loop.fromLevel <= level)
                contours[s].push_back(cut(loop, groupRays[loop.group]->next(), plane));
            else
                contours[s].emplace_back();
        }
    });
    addFoldRays(contours, level);
    return contours;
}

Contour Reconstruction::cut(const SliceLoop& loop, const RaySet& rays, const SlicePlane& plane)
{
    return loop.onPolygon ? castPolygon(loop.view, rays) : castRays(loop.view, rays, plane);
}

Contour Reconstruction::refine(const Contour& coarse, const SliceLoop& loop, const RaySet& rays,
                               const SlicePlane& plane)
{
    // Crossings on a polygon (a waist, a contour carried to a slab's middle) are cast anew: that
    // gives the coarse ones bit for bit.
    return loop.onPolygon ? castPolygon(loop.view, rays) : refineContour(coarse, loop.view, rays, plane);
}

void Reconstruction::addFoldRays(Contours& contours, int level) const
{
    // Half a voxel: a smooth tube's top level stays well within it (the phantom's is 0.16 voxel
    // from the isosurface), so a fold chord farther than that from its boundary stands out.
    // The top level, which must stay within a voxel, halves sectors whose edges cut corners too,
    // once more than folds: rays from a dense tree's centre meet an arm seen end-on, 15 to 39
    // pixels away, far apart along its walls, and its bands there were 1.20 voxels off after two
    // halvings (0.68 after three, for 0.55% more triangles over 12 dense trees). A third halving
    // for folds too put new rays through folds that the next section lacks: 1.93 voxels where
    // another tree was 0.89.
    constexpr double kFoldTolerance = 0.5;
    const bool top = level == mOptions.levels - 1;
    const std::size_t groups = mTubes.size(); // group ids are tube indices
    // A triangle of a band across a slab t thick, on a chord L long, has an aspect ratio of at
    // least sqrt(3)/2 L / t where the surface stands square to the planes (its height over the
    // chord is t): past kLargestAspect whatever the tiling once L > 2 / sqrt(3) kLargestAspect t.
    // An event's slabs are an eighth of a voxel thick, and rays from a central point far along a
    // straight wall meet it up to 25 voxels apart. A contour halves such chords, at every level as
    // often as at the top: the T branch's level 1 was 1.34 voxels off where it could halve them
    // twice, 0.69 with three halvings, for 21% more triangles there (0.6% on the shared smoke).
    const double longestChord = 2.0 / std::sqrt(3.0) * kLargestAspect;
    const std::vector<double> thinnest = thinnestSlabs();
    for (int round = 0; round <= RaySet::kFoldDepth; ++round) {
        std::vector<std::vector<std::vector<int>>> flagged(mLoops.size()); // per plane, per loop
        forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
            for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
                flagged[s].emplace_back();
                const Contour& contour = contours[s][l];
                if (mLoops[s][l].group < 0 || contour.crossings.empty()) continue;
                for (int x : hiddenFolds(contour, mLoops[s][l].view, kFoldTolerance))
                    if (contour.rays.canHalve(x, RaySet::kFoldHalvings)) flagged[s].back().push_back(x);
                for (int x : longChords(contour, longestChord * thinnest[s]))
                    if (contour.rays.canHalve(x)) flagged[s].back().push_back(x);
                if (!top) continue;
                const std::vector<int> cut = strayingChords(contour, mLoops[s][l].view, kFoldTolerance);
                flagged[s].back().insert(flagged[s].back().end(), cut.begin(), cut.end());
            }
        });
        std::vector<std::vector<int>> sectors(groups);
        std::vector<const RaySet*> current(groups, nullptr);
        for (std::size_t s = 0; s < mLoops.size(); ++s)
            for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
                const int g = mLoops[s][l].group;
                if (g < 0 || flagged[s][l].empty()) continue;
                sectors[g].insert(sectors[g].end(), flagged[s][l].begin(), flagged[s][l].end());
                current[g] = &contours[s][l].rays;
            }
        std::vector<RaySet> grown(groups);
        std::vector<bool> grows(groups, false);
        bool any = false;
        for (std::size_t g = 0; g < groups; ++g) {
            if (!current[g]) continue;
            std::sort(sectors[g].begin(), sectors[g].end());
            sectors[g].erase(std::unique(sectors[g].begin(), sectors[g].end()), sectors[g].end());
            grown[g] = current[g]->withMidpoints(sectors[g]);
            grows[g] = grown[g].count() != current[g]->count();
            any = any || grows[g];
        }
        if (!any) return;
        forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
            bool touched = false;
            for (const SliceLoop& l : mLoops[s]) touched = touched || (l.group >= 0 && grows[l.group]);
            if (!touched) return;
            const SlicePlane plane(mVolume, mPlan, mPositions[s]);
            for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
                const int g = mLoops[s][l].group;
                if (g >= 0 && grows[g] && !contours[s][l].crossings.empty())
                    contours[s][l] = refine(contours[s][l], mLoops[s][l], grown[g], plane);
            }
        });
    }
}

std::vector<double> Reconstruction::thinnestSlabs() const
{
    std::vector<double> sorted = mPositions;
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    std::vector<double> thinnest(mPositions.size(), std::numeric_limits<double>::infinity());
    for (std::size_t s = 0; s < mPositions.size(); ++s) {
        const auto at = std::lower_bound(sorted.begin(), sorted.end(), mPositions[s]);
        if (at != sorted.begin()) thinnest[s] = *at - *(at - 1);
        if (at + 1 != sorted.end()) thinnest[s] = std::min(thinnest[s], *(at + 1) - *at);
    }
    return thinnest;
}

// One level's mesh as assemble() puts it together. The constructor numbers every vertex (the
// tubes' members in tube order, then each junction's nodes and parts' crossings) and places it;
// build() tiles the bands, caps and junction parts, in that order. It refers to the
// reconstruction and the level's contours, which must outlive it; build() is called once.
class Reconstruction::Assembly {
public:
    Assembly(const Reconstruction& reconstruction, const Contours& contours, int level);
    LevelMesh build(const std::vector<glm::dvec3>& coarser);
    /// Per junction `asked`, whether a triangle of its parts lies farther than `reach` voxels
    /// from the isosurface (straysFrom).
    std::vector<bool> strayingJunctions(const std::vector<bool>& asked, double reach);
    /// Of the bands `asked` (by their lower contour's plane and loop), those with a triangle
    /// farther than `reach` voxels from the isosurface at points all over it (straysAnywhere:
    /// outside the object only for those of `ends`, bands to end contours), as the level tiles
    /// them.
    std::set<std::pair<int, int>> strayingBands(const std::set<std::pair<int, int>>& asked,
                                                const std::set<std::pair<int, int>>& ends, double reach);

private:
    // Every contour of every tube in tube order, with the index of its first vertex. A fan cap's
    // apex follows the first (or last) contour of its tube. Contours, trees and bands are then
    // built in parallel and joined in this order, so the mesh does not depend on the threads.
    struct Member {
        const Tube* tube;
        bool startsTube, endsTube; // the tube's first and last contour (at every level: ends are kept)
        const Contour* contour;
        int slice, loop;
        std::uint32_t first;   // index of its first vertex
        std::uint32_t apex[2]; // bottom, top cap apex (members that end a tube with a fan)
    };
    // A vertex on a member's contour edge that its own crossings do not give (numberJunctionVertices).
    struct Extra {
        int segment;
        double param;
        std::uint32_t id;
        glm::dvec2 point;
    };
    using Chord = std::pair<int, int>;
    // Parts' crossings on each chord, with their place along it (0 at its lower node).
    using ChordVertices = std::map<Chord, std::vector<std::pair<double, std::uint32_t>>>;
    // A contour's ring: its crossings in walk order with its extras merged in by their place on
    // the polygon; after[k] lists those between crossings k and k+1.
    struct Ring {
        std::vector<std::uint32_t> ids;
        std::vector<glm::dvec2> points; // in-plane, pixel units
        std::vector<std::vector<std::uint32_t>> after;
    };
    // The band between contour `lower` (its crossings ids from lowerFirst) and `upper` above it,
    // in band-local ids: the lower contour's crossings, then the upper one's.
    struct Side {
        const Contour* contour;
        const ContourString* string; // with the contour tree tiler
        const ContourTree* tree;
        std::uint32_t first;
    };

    void collectMembers();
    void castParts();
    void numberJunctionVertices();
    void numberPatchVertices();
    void placeVertices();
    void addWallVertices(const std::vector<glm::dvec3>& coarser);
    std::vector<double> chordPieces(std::size_t i) const;
    std::size_t memberAt(const std::pair<int, int>& loop) const;
    // A member's ring as it stands before the patches' points join it (its crossings, a junction's
    // nodes and parts' crossings), by position: ordered by x, then by id.
    using RingPoints = std::vector<std::pair<glm::dvec2, std::uint32_t>>;
    RingPoints ringPoints(std::size_t i) const;
    // The vertex of `ring` (`loop`'s, from ringPoints) that lies at the loop's point `point`, if one
    // does.
    std::optional<std::uint32_t> vertexAtPoint(const std::pair<int, int>& loop, int point,
                                               const RingPoints& ring) const;
    glm::dvec3 toWorld(const glm::dvec2& uv, int plane) const;
    Ring ringOf(std::size_t i) const;
    void splitForExtras(std::vector<Triangle>& triangles, std::size_t i) const;
    void buildTrees();
    // `byArea`: the contour trees' band was out of register and the least-area tiler's was taken.
    std::vector<Triangle> tileSides(const Side& lowerSide, const Side& upperSide, std::size_t& bytes,
                                    bool& byArea) const;
    // The contour trees' band (the paper's tiler), each tree ranked against the other; none where
    // it is out of register.
    static std::optional<std::vector<Triangle>> tileByTrees(const Side& lowerSide, const Side& upperSide,
                                                            std::size_t& bytes);
    // A toroidal tiler's band over the contours' world-space points: the baselines', and the
    // contour trees' fallback.
    using ToroidalTiler = std::vector<Triangle> (*)(const std::vector<glm::dvec3>&, const std::vector<glm::dvec3>&,
                                                    ToroidalStats*);
    std::vector<Triangle> tileToroidal(const Side& lowerSide, const Side& upperSide, std::size_t& bytes,
                                       ToroidalTiler tiler) const;
    // Whether the band joins a point more than kBandOutOfRegister pixels farther than a point of
    // the other contour nearer it (about each contour's mean crossing): where the contour trees'
    // parses of two noisy contours' excursions differ.
    static bool outOfRegister(const std::vector<Triangle>& band, const Side& lower, const Side& upper);
    Side sideOf(std::size_t i) const;
    static void place(std::vector<Triangle>& band, const Side& lower, const Side& upper, bool flip);
    void tileBands();
    std::vector<Triangle> tileRings(std::size_t i) const;
    std::vector<Triangle> tileByArea(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper,
                                     bool flip) const;
    ContourTree treeOf(std::size_t i) const;
    void emitCap(std::size_t self, bool top);
    void emitBandsAndCaps();
    void tileJunction(std::size_t j);
    std::vector<std::uint32_t> partBoundary(std::size_t j, std::size_t k, const Ring& ring, const Ring& innerRing,
                                            const ChordVertices& chords) const;
    void tilePart(std::size_t j, std::size_t k, const std::vector<std::uint32_t>& boundary);
    void tileSlit(std::size_t j, const Ring& ring, const Ring& innerRing, const ChordVertices& chords);
    void tilePatch(std::size_t p);

    // The reconstruction's state, under its own names.
    const Volume& mVolume;
    const SlicePlan& mPlan;
    const MeshOptions& mOptions;
    const std::vector<double>& mPositions;
    const std::vector<std::vector<SliceLoop>>& mLoops;
    const std::vector<Tube>& mTubes;
    const std::vector<Junction>& mJunctions;
    const std::vector<Patch>& mPatches;

    const Contours& contours;
    const RaySet rays;
    const bool mirrored;
    const std::vector<double> thinnest; // per plane: the thinnest slab beside it (thinnestSlabs)
    LevelMesh result;
    TriangleMesh& mesh = result.mesh;
    std::vector<Member> members;
    std::vector<std::size_t> tubeFirst;     // index in `members` of each tube's first
    std::vector<std::vector<int>> memberOf; // per plane and loop; -1: not tiled
    std::uint32_t vertexCount = 0;
    std::vector<std::vector<Contour>> parts;                        // per junction, per partner
    std::vector<std::vector<Extra>> extras;                         // per member
    std::vector<ChordVertices> onChord;                             // per junction
    std::vector<std::uint32_t> firstNodeOf;                         // per junction
    std::vector<std::vector<std::uint32_t>> partFirst;              // per junction, per partner
    std::vector<std::pair<std::uint32_t, glm::dvec3>> partVertices; // the parts' crossings' positions
    std::vector<std::vector<std::uint32_t>> patchIds;               // per patch, per vertex
    std::vector<std::unique_ptr<ContourTree>> trees;                // per member, with the contour tree tiler
    std::vector<ContourString> strings;                             // per member, likewise
    std::vector<std::size_t> bandBytes;                             // per member
    std::vector<std::vector<Triangle>> bands;                       // per member: the band to the one before it
    std::vector<char> walled; // per member: it has wall vertices (addWallVertices)
};

Reconstruction::Assembly::Assembly(const Reconstruction& r, const Contours& contours, int level)
    : mVolume(r.mVolume),
      mPlan(r.mPlan),
      mOptions(r.mOptions),
      mPositions(r.mPositions),
      mLoops(r.mLoops),
      mTubes(r.mTubes),
      mJunctions(r.mJunctions),
      mPatches(r.mPatches),
      contours(contours),
      rays{r.mOptions.baseRays, level},
      mirrored(r.mVolume.mirrored()),
      thinnest(r.thinnestSlabs()),
      tubeFirst(r.mTubes.size()),
      memberOf(r.mLoops.size()),
      parts(r.mJunctions.size()),
      onChord(r.mJunctions.size()),
      firstNodeOf(r.mJunctions.size()),
      partFirst(r.mJunctions.size()),
      patchIds(r.mPatches.size())
{
    result.level = level;
    result.rays = rays.count();
    collectMembers();
    castParts();
    numberJunctionVertices();
    numberPatchVertices();
    placeVertices();
}

void Reconstruction::Assembly::collectMembers()
{
    for (std::size_t s = 0; s < mLoops.size(); ++s) memberOf[s].assign(mLoops[s].size(), -1);
    for (const Tube& tube : mTubes) {
        tubeFirst[&tube - mTubes.data()] = members.size();
        for (std::size_t k = 0; k < tube.members.size(); ++k) {
            const auto [s, l] = tube.members[k];
            if (mLoops[s][l].fromLevel > result.level) {
                ++result.skippedContours;
                continue;
            }
            const bool startsTube = k == 0, endsTube = k + 1 == tube.members.size();
            const Contour& c = contours[s][l];
            PIPETILE_ASSERT(!c.crossings.empty() &&
                                countEdges(c, EdgeType::Forward) - countEdges(c, EdgeType::Backward) ==
                                    c.rays.count() &&
                                c.rays.count() == contours[tube.members[0].first][tube.members[0].second].rays.count(),
                            "a contour does not wind once (#F - #B != n), or differs in rays from its tube");
            if (startsTube) result.addedRays += c.rays.count() - rays.count();
            ++result.contours;
            result.ambiguousContours += isUnambiguous(c) ? 0 : 1;
            result.interpolationFallbacks += c.interpolationFallbacks;
            result.crossings += static_cast<long long>(c.crossings.size());
            Member member{&tube, startsTube, endsTube, &c, s, l, vertexCount, {0, 0}};
            memberOf[s][l] = static_cast<int>(members.size());
            vertexCount += static_cast<std::uint32_t>(c.crossings.size());
            if (startsTube && tube.bottom.fan) member.apex[0] = vertexCount++;
            if (endsTube && tube.top.fan) member.apex[1] = vertexCount++;
            members.push_back(member);
        }
    }
}

// Junction vertices. Nodes, the same at every level (junction.nodePoints); then each part's
// crossings: the partner's rays cast against the part's polygon, so that the part is tiled to
// the partner like any band. A part that gives no contour (no crossings) is tiled by the
// minimum-area tiler instead.
void Reconstruction::Assembly::castParts()
{
    forEachIndex(mOptions.threads, mJunctions.size(), [&](std::size_t j) {
        const Junction& junction = mJunctions[j];
        for (std::size_t k = 0; k < junction.parts.size(); ++k) {
            const auto [ps, pl] = junction.many[k];
            Contour c = castPolygon(junction.parts[k].view, contours[ps][pl].rays);
            if (countEdges(c, EdgeType::Forward) - countEdges(c, EdgeType::Backward) != c.rays.count())
                c.crossings.clear();
            parts[j].push_back(std::move(c));
        }
    });
}

// Extras: the vertices on a member's contour edges that its own crossings do not give (cuts,
// and the parts' crossings on its arcs), by polygon segment and place along it (0 at its
// first point). Parts' crossings on chords: per junction, by the chord's nodes (lower first).
void Reconstruction::Assembly::numberJunctionVertices()
{
    extras.resize(members.size());
    for (std::size_t j = 0; j < mJunctions.size(); ++j) {
        const Junction& junction = mJunctions[j];
        firstNodeOf[j] = vertexCount;
        for (std::size_t node = 0; node < junction.nodeOn.size(); ++node) {
            const auto [member, point] = junction.nodeOn[node];
            extras[memberAt(member == 0 ? junction.single : junction.inner)].push_back(
                {point, 0.0, vertexCount + static_cast<std::uint32_t>(node), junction.nodePoints[node]});
        }
        vertexCount += static_cast<std::uint32_t>(junction.nodePoints.size());
        for (const Contour& part : parts[j]) {
            partFirst[j].push_back(vertexCount);
            vertexCount += static_cast<std::uint32_t>(part.crossings.size());
        }
        for (std::size_t k = 0; k < parts[j].size(); ++k) {
            const std::vector<Junction::Part::Corner>& corners = junction.parts[k].corners;
            const std::vector<Crossing>& x = parts[j][k].crossings;
            for (std::size_t c = 0; c < x.size(); ++c) {
                const std::uint32_t id = partFirst[j][k] + static_cast<std::uint32_t>(c);
                const Junction::Part::Corner &a = corners[x[c].segment],
                                             &b = corners[(x[c].segment + 1) % corners.size()];
                const std::pair<int, int> loop = a.member == 1 ? junction.inner : junction.single;
                const std::vector<glm::dvec2>& polygon = mLoops[loop.first][loop.second].view.polygon;
                const int size = static_cast<int>(polygon.size());
                if (a.member >= 0 && a.member == b.member &&
                    (b.point == (a.point + 1) % size || a.point == (b.point + 1) % size)) {
                    // On an arc: a segment of that contour's polygon.
                    const int s = b.point == (a.point + 1) % size ? a.point : b.point;
                    extras[memberAt(loop)].push_back(
                        {s, placeOn(polygon[s], polygon[(s + 1) % size], x[c].point), id, x[c].point});
                    partVertices.push_back({id, toWorld(x[c].point, loop.first)});
                } else { // on a chord between two nodes
                    const Chord chord{std::min(a.node, b.node), std::max(a.node, b.node)};
                    const double t =
                        placeOn(junction.nodePoints[chord.first], junction.nodePoints[chord.second], x[c].point);
                    onChord[j][chord].push_back({t, id});
                    partVertices.push_back({id, mVolume.indexToWorld(glm::mix(junction.nodeIndex[chord.first],
                                                                              junction.nodeIndex[chord.second], t))});
                }
            }
        }
    }
}

// A patch's vertices: its own inside the slab, and its points on the loops, which join their rings.
void Reconstruction::Assembly::numberPatchVertices()
{
    // A patch's points on a loop lie on its polygon's points (param 0 of their segment; a hole's
    // polygon runs reversed). Two patches that meet at a loop (one either side of its plane) share
    // its points: as copies, the patches' edges on the loop were split through each other's copy
    // too, into triangles of no area, and a collapse guarded by the worst aspect ratio it takes
    // away could then make any needle (the smoke at iso 0.1: 69 486 at the top level).
    std::map<std::array<int, 3>, std::uint32_t> onLoop; // (plane, loop, point): its vertex
    std::map<std::size_t, RingPoints> rings;            // per member with a patch's points
    for (std::size_t p = 0; p < mPatches.size(); ++p) {
        const std::vector<SlabPatch::Vertex>& vertices = mPatches[p].surface.vertices;
        for (const SlabPatch::Vertex& vertex : vertices) {
            if (vertex.plane < 0) {
                patchIds[p].push_back(vertexCount++);
                continue;
            }
            const std::pair<int, int> loop{vertex.plane == 0 ? mPatches[p].below : mPatches[p].above, vertex.loop};
            // A ray along a pixel row or column meets the loop at its point, as can a junction's
            // part: the patch takes that vertex, which one of its own would join by an edge of no
            // length.
            const std::size_t member = memberAt(loop);
            auto ring = rings.find(member);
            if (ring == rings.end()) ring = rings.emplace(member, ringPoints(member)).first;
            const std::optional<std::uint32_t> shared = vertexAtPoint(loop, vertex.point, ring->second);
            const auto [at, added] =
                onLoop.insert({{loop.first, loop.second, vertex.point}, shared ? *shared : vertexCount});
            patchIds[p].push_back(at->second);
            if (!added || shared) continue;
            const BoundaryLoop& boundary = mLoops[loop.first][loop.second].loop;
            const int n = static_cast<int>(boundary.points.size());
            const int segment = boundary.hole() ? n - 1 - vertex.point : vertex.point;
            extras[member].push_back({segment, 0.0, vertexCount++, boundary.points[vertex.point]});
        }
    }
}

std::optional<std::uint32_t> Reconstruction::Assembly::vertexAtPoint(const std::pair<int, int>& loop, int point,
                                                                     const RingPoints& ring) const
{
    // Crossings are placed to about 1e-12 pixel.
    constexpr double kSamePoint = 1e-9;
    const auto same = [](const glm::dvec2& a, const glm::dvec2& b) { return glm::length(a - b) <= kSamePoint; };
    const std::vector<glm::dvec2>& points = mLoops[loop.first][loop.second].loop.points;
    const std::size_t n = points.size(), k = static_cast<std::size_t>(point);
    const glm::dvec2 at = points[k];
    // A point the polygon holds twice (a sample on the isovalue) keeps its copies: which of them a
    // crossing stands for, the ring's order could not tell.
    if (same(points[(k + 1) % n], at) || same(points[(k + n - 1) % n], at)) return std::nullopt;
    const auto from = std::lower_bound(ring.begin(), ring.end(), at.x - kSamePoint,
                                       [](const auto& entry, double x) { return entry.first.x < x; });
    for (auto it = from; it != ring.end() && it->first.x <= at.x + kSamePoint; ++it)
        if (same(it->first, at)) return it->second;
    return std::nullopt;
}

Reconstruction::Assembly::RingPoints Reconstruction::Assembly::ringPoints(std::size_t i) const
{
    RingPoints ring;
    const std::vector<Crossing>& x = members[i].contour->crossings;
    for (std::size_t c = 0; c < x.size(); ++c)
        ring.push_back({x[c].point, members[i].first + static_cast<std::uint32_t>(c)});
    for (const Extra& e : extras[i]) ring.push_back({e.point, e.id});
    std::sort(ring.begin(), ring.end(), [](const auto& a, const auto& b) {
        return a.first.x != b.first.x ? a.first.x < b.first.x : a.second < b.second;
    });
    return ring;
}

std::size_t Reconstruction::Assembly::memberAt(const std::pair<int, int>& loop) const
{
    return static_cast<std::size_t>(memberOf[loop.first][loop.second]);
}

glm::dvec3 Reconstruction::Assembly::toWorld(const glm::dvec2& uv, int plane) const
{
    return mVolume.indexToWorld(planeToIndex(mPlan.axis, uv, mPositions[plane]));
}

void Reconstruction::Assembly::placeVertices()
{
    mesh.vertices.resize(vertexCount);
    forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
        const Member& m = members[i];
        for (std::size_t j = 0; j < m.contour->crossings.size(); ++j)
            mesh.vertices[m.first + j] = toWorld(m.contour->crossings[j].point, m.slice);
        if (m.startsTube && m.tube->bottom.fan)
            mesh.vertices[m.apex[0]] = mVolume.indexToWorld(m.tube->bottom.apexIndex);
        if (m.endsTube && m.tube->top.fan) mesh.vertices[m.apex[1]] = mVolume.indexToWorld(m.tube->top.apexIndex);
    });
    for (std::size_t j = 0; j < mJunctions.size(); ++j) {
        const Junction& junction = mJunctions[j];
        for (std::size_t node = 0; node < junction.nodeIndex.size(); ++node)
            mesh.vertices[firstNodeOf[j] + node] = mVolume.indexToWorld(junction.nodeIndex[node]);
    }
    for (const auto& [id, position] : partVertices) mesh.vertices[id] = position;
    // Last, so that a vertex a patch's point shares (numberPatchVertices) lies at that point, within
    // 1e-9 pixel of where its ray or part put it: at every level, as the patch is the same, while
    // that ray's crossing may be new at this one.
    for (std::size_t p = 0; p < mPatches.size(); ++p)
        for (std::size_t v = 0; v < mPatches[p].surface.vertices.size(); ++v) {
            const SlabPatch::Vertex& vertex = mPatches[p].surface.vertices[v];
            const int plane = vertex.plane == 0 ? mPatches[p].below : mPatches[p].above;
            mesh.vertices[patchIds[p][v]] = vertex.plane < 0
                                                ? mVolume.indexToWorld(vertex.index)
                                                : toWorld(mLoops[plane][vertex.loop].loop.points[vertex.point], plane);
        }
}

// Wall vertices: polygon points added as extras where the rays leave a contour edge no band can
// follow. At the top level, where an edge between a tube's ends strays more than a voxel from the
// boundary it stands for (wallPoints), the points that keep it within half a voxel: rays from the
// central point cannot reach such a wall (it points at the centre), and the sectors' halvings stop
// at RaySet::kFoldDepth. At every level, where an edge is too long for a band beside it to have no
// needle, points that cut it into pieces half that long (longChordPoints, chordPieces). The wall
// vertices of the `coarser` levels stay, so levels still nest: a polygon point where a coarser
// level has a vertex is one of them, unless this level has a vertex there already. The bands
// beside such a contour are tiled from the rings (tileBands).
void Reconstruction::Assembly::addWallVertices(const std::vector<glm::dvec3>& coarser)
{
    walled.assign(members.size(), 0);
    if (mOptions.tiler != TilerKind::ContourTree) return;
    const bool top = result.level == mOptions.levels - 1;
    // Pixels: an edge farther than the top level's bound (a voxel) from its walk gets vertices that
    // bring it within half a voxel, as the straying chords' rays do (addFoldRays). With any edge
    // past half a voxel, three random crops of the smoke were up to 0.1 voxel farther off and one
    // gained a needle of aspect 142.
    constexpr double kWallReach = 1.0, kWallTolerance = 0.5;
    const std::vector<PositionKey> coarse = sortedKeys(coarser), placed = sortedKeys(mesh.vertices);
    auto among = [](const std::vector<PositionKey>& keys, const glm::dvec3& p) {
        return std::binary_search(keys.begin(), keys.end(), positionKey(p));
    };
    std::vector<std::vector<int>> points(members.size());
    forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
        const Member& m = members[i];
        const LoopView& view = mLoops[m.slice][m.loop].view;
        std::vector<int>& chosen = points[i];
        // Tube ends, and contours with extras of their own, are capped or joined: left as they are.
        if (!m.startsTube && !m.endsTube && extras[i].empty()) {
            if (top) {
                for (const std::vector<int>& between : wallPoints(*m.contour, view, kWallReach, kWallTolerance))
                    chosen.insert(chosen.end(), between.begin(), between.end());
            }
            for (const std::vector<int>& between : longChordPoints(*m.contour, view, chordPieces(i)))
                chosen.insert(chosen.end(), between.begin(), between.end());
        }
        if (!coarse.empty())
            for (std::size_t s = 0; s < view.polygon.size(); ++s)
                if (among(coarse, toWorld(view.polygon[s], m.slice))) chosen.push_back(static_cast<int>(s));
        std::sort(chosen.begin(), chosen.end());
        chosen.erase(std::unique(chosen.begin(), chosen.end()), chosen.end());
        // A point that is a vertex already (a crossing cast on the polygon, a patch's) stays one.
        chosen.erase(std::remove_if(chosen.begin(), chosen.end(),
                                    [&](int s) { return among(placed, toWorld(view.polygon[s], m.slice)); }),
                     chosen.end());
    });
    for (std::size_t i = 0; i < members.size(); ++i) {
        const std::vector<glm::dvec2>& polygon = mLoops[members[i].slice][members[i].loop].view.polygon;
        for (const int s : points[i]) {
            extras[i].push_back({s, 0.0, vertexCount++, polygon[s]});
            mesh.vertices.push_back(toWorld(polygon[s], members[i].slice));
            walled[i] = 1;
            ++result.wallVertices;
        }
    }
}

// Per edge of member i's contour (a tube's inner member), how long the pieces that longChordPoints
// cuts it into may be, or 0 where its bands need no cut. A band's triangle on an edge L long
// stands h high, h = sqrt(t^2 + d^2) over a slab t thick where the other contour's boundary lies d
// off the edge in the plane: an aspect ratio of at least sqrt(3)/2 L / h, past kLargestAspect once
// L > 2 / sqrt(3) kLargestAspect h (addFoldRays' longChords takes d = 0). The pieces are cut to
// kCollapseAspect's length, which the needle passes leave as tiled. The level's own slabs: coarse
// levels skip slices, and their bands span several.
std::vector<double> Reconstruction::Assembly::chordPieces(std::size_t i) const
{
    const double longest = 2.0 / std::sqrt(3.0) * kLargestAspect, piece = 2.0 / std::sqrt(3.0) * kCollapseAspect;
    const std::vector<Crossing>& x = members[i].contour->crossings;
    const std::size_t neighbours[2] = {i - 1, i + 1};
    double thinner = std::numeric_limits<double>::infinity();
    for (std::size_t n : neighbours)
        thinner = std::min(thinner, std::abs(mPositions[members[n].slice] - mPositions[members[i].slice]));
    std::vector<double> pieces(x.size(), 0.0);
    for (std::size_t k = 0; k < x.size(); ++k) {
        const glm::dvec2 a = x[k].point, b = x[(k + 1) % x.size()].point;
        const double length = glm::distance(a, b);
        if (length <= longest * thinner) continue; // no band on it can be that flat
        double h = std::numeric_limits<double>::infinity();
        for (std::size_t n : neighbours) {
            const double t = mPositions[members[n].slice] - mPositions[members[i].slice];
            const double d = polygonClearance(mLoops[members[n].slice][members[n].loop].view.polygon, 0.5 * (a + b));
            h = std::min(h, std::hypot(t, d));
        }
        if (length > longest * h) pieces[k] = piece * h;
    }
    return pieces;
}

// A contour's ring: its crossings in walk order with its extras merged in by their place on
// the polygon; after[k] lists those between crossings k and k+1.
Reconstruction::Assembly::Ring Reconstruction::Assembly::ringOf(std::size_t i) const
{
    const Member& m = members[i];
    const Contour& contour = *m.contour;
    const std::vector<Crossing>& x = contour.crossings;
    const std::vector<glm::dvec2>& polygon = mLoops[m.slice][m.loop].view.polygon;
    const long long segments = static_cast<long long>(polygon.size());
    // Where a crossing lies along its segment: where its ray meets the polygon.
    auto placeOf = [&](const Crossing& c) {
        const glm::dvec2 onPolygon = contour.center + (c.t > 0.0 ? c.crackT / c.t : 0.0) * (c.point - contour.center);
        return placeOn(polygon[c.segment], polygon[(c.segment + 1) % segments], onPolygon);
    };
    // Walk positions from crossing 0, which starts the walk: a crossing earlier on its
    // segment, or an extra before it on its segment, comes last.
    auto key = [&](long long segment) { return (segment - x[0].segment + segments) % segments; };
    std::vector<long long> crossingKey(x.size());
    for (std::size_t k = 0; k < x.size(); ++k)
        crossingKey[k] = key(x[k].segment) == 0 && x[k].along < x[0].along ? segments : key(x[k].segment);
    const double startPlace = extras[i].empty() ? 0.0 : placeOf(x[0]);
    std::vector<std::pair<std::pair<long long, double>, const Extra*>> placed;
    for (const Extra& e : extras[i]) {
        const long long k = key(e.segment);
        placed.push_back({{k == 0 && e.param <= startPlace ? segments : k, e.param}, &e});
    }
    std::sort(placed.begin(), placed.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first < b.first : a.second->id < b.second->id;
    });
    std::vector<std::vector<const Extra*>> after(x.size());
    for (const auto& [at, e] : placed) {
        std::size_t before = std::lower_bound(crossingKey.begin(), crossingKey.end(), at.first) - crossingKey.begin();
        while (before < x.size() && crossingKey[before] == at.first && placeOf(x[before]) < at.second) ++before;
        after[before - 1].push_back(e);
    }
    Ring ring;
    ring.after.resize(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) {
        ring.ids.push_back(m.first + static_cast<std::uint32_t>(k));
        ring.points.push_back(x[k].point);
        for (const Extra* e : after[k]) {
            ring.after[k].push_back(e->id);
            ring.ids.push_back(e->id);
            ring.points.push_back(e->point);
        }
    }
    return ring;
}

// Extras lie on contour edges that the bands and caps tile as single edges: the triangle on
// each such edge becomes a fan through them.
void Reconstruction::Assembly::splitForExtras(std::vector<Triangle>& triangles, std::size_t i) const
{
    if (extras[i].empty()) return;
    const Ring ring = ringOf(i);
    const std::uint32_t count = static_cast<std::uint32_t>(members[i].contour->crossings.size());
    for (std::uint32_t k = 0; k < count; ++k)
        if (!ring.after[k].empty())
            splitEdge(triangles, members[i].first + k, members[i].first + (k + 1) % count, ring.after[k]);
}

// Contour trees, one per contour; where a sector is ambiguous, each band ranks its two
// contours against each other (rule [1'], below), so the trees may differ from band to band.
void Reconstruction::Assembly::buildTrees()
{
    trees.resize(members.size());
    strings.resize(members.size());
    if (mOptions.tiler == TilerKind::ContourTree) {
        forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
            strings[i] = contourString(*members[i].contour);
            trees[i] = std::make_unique<ContourTree>(strings[i]);
        });
        for (const std::unique_ptr<ContourTree>& tree : trees) {
            result.ambiguousSectors += tree->ambiguousSectors();
            result.tilingBytes += tree->bytes();
        }
    }
}

// The band between contour `lower` (its crossings ids from lowerFirst) and `upper` above it,
// in band-local ids: the lower contour's crossings, then the upper one's.
std::vector<Triangle> Reconstruction::Assembly::tileSides(const Side& lowerSide, const Side& upperSide,
                                                          std::size_t& bytes, bool& byArea) const
{
    byArea = false;
    if (mOptions.tiler == TilerKind::ContourTree) {
        if (std::optional<std::vector<Triangle>> band = tileByTrees(lowerSide, upperSide, bytes))
            return std::move(*band);
        // Two noisy contours whose excursions the contour trees parse differently can be paired
        // far out of register (a ring tree's notch: crossings 12 pixels apart, 1.4 voxels off
        // the surface): such a band, or junction part, is tiled by area instead, ties broken by
        // the shorter spans (tileLeastAreaNearest).
        byArea = true;
        return tileToroidal(lowerSide, upperSide, bytes, tileLeastAreaNearest);
    }
    return tileToroidal(lowerSide, upperSide, bytes, mOptions.tiler == TilerKind::Greedy ? tileGreedy : tileOptimal);
}

std::optional<std::vector<Triangle>> Reconstruction::Assembly::tileByTrees(const Side& lowerSide, const Side& upperSide,
                                                                           std::size_t& bytes)
{
    // Rule [1'] per band: the lower contour keeps in each ambiguous sector the F edge closest to
    // the upper contour's, then the upper one the F edge closest to that choice. Ranking each
    // contour once, against the contour below it only, carried a choice made for one band into
    // the next, where the upper contour's sector can hold the other F edge (bean: the arm tip
    // grows past a ray between two slices) and the traversal then paired the tip with the hole's
    // wall.
    const ContourTree* lower = lowerSide.tree;
    const ContourTree* upper = upperSide.tree;
    std::unique_ptr<ContourTree> rankedLower, rankedUpper;
    if (lower->ambiguousSectors() > 0) {
        rankedLower = std::make_unique<ContourTree>(
            *lowerSide.string, rankAgainstNeighbour(*lowerSide.contour, *lowerSide.string, *upperSide.contour, *upper));
        lower = rankedLower.get();
        bytes += lower->bytes();
    }
    if (upper->ambiguousSectors() > 0) {
        rankedUpper = std::make_unique<ContourTree>(
            *upperSide.string, rankAgainstNeighbour(*upperSide.contour, *upperSide.string, *lowerSide.contour, *lower));
        upper = rankedUpper.get();
        bytes += upper->bytes();
    }
    std::vector<Triangle> band = tileBand(*lower, *upper);
    if (outOfRegister(band, lowerSide, upperSide)) return std::nullopt;
    return band;
}

std::vector<Triangle> Reconstruction::Assembly::tileToroidal(const Side& lowerSide, const Side& upperSide,
                                                             std::size_t& bytes, ToroidalTiler tiler) const
{
    // The baselines see the same contours as world-space points.
    const auto first = mesh.vertices.begin();
    const std::uint32_t lowerCount = static_cast<std::uint32_t>(lowerSide.contour->crossings.size());
    const std::vector<glm::dvec3> a(first + lowerSide.first, first + lowerSide.first + lowerCount);
    const std::vector<glm::dvec3> b(first + upperSide.first,
                                    first + upperSide.first + upperSide.contour->crossings.size());
    ToroidalStats stats;
    std::vector<Triangle> band = tiler(a, b, &stats);
    bytes += stats.bytes;
    // A strip that fans one point over the whole other contour is no manifold (the oblique
    // tube's tiny sections with --tiler optimal, before this).
    return withoutFullFans(band, lowerCount, static_cast<std::uint32_t>(b.size()));
}

bool Reconstruction::Assembly::outOfRegister(const std::vector<Triangle>& band, const Side& lower, const Side& upper)
{
    const std::uint32_t m = static_cast<std::uint32_t>(lower.contour->crossings.size());
    const std::uint32_t n = static_cast<std::uint32_t>(upper.contour->crossings.size());
    // Contours that each ray crosses once pair ray by ray: only excursions (a ray crossing three
    // times or more) can be parsed differently.
    if (m == static_cast<std::uint32_t>(lower.contour->rays.count()) &&
        n == static_cast<std::uint32_t>(upper.contour->rays.count()))
        return false;
    // In-plane, from each contour's mean crossing: a tube that leans pairs its points as its
    // sections moved, not where they lie in the plane (a central point can jump within a noisy
    // section, where the mean stays).
    const auto mean = [](const Contour& c) {
        glm::dvec2 sum(0.0);
        for (const Crossing& x : c.crossings) sum += x.point;
        return sum / static_cast<double>(c.crossings.size());
    };
    const glm::dvec2 lowerMean = mean(*lower.contour), upperMean = mean(*upper.contour);
    const auto at = [&](std::uint32_t v) {
        return v < m ? lower.contour->crossings[v].point - lowerMean
                     : upper.contour->crossings[v - m].point - upperMean;
    };
    // Each contour's points by u, for the points within a distance of one (a window of u); sorted
    // on the first spanning edge longer than kBandOutOfRegister (most bands have none).
    std::vector<std::pair<double, std::uint32_t>> byU[2];
    const auto sorted = [&](int side) -> const std::vector<std::pair<double, std::uint32_t>>& {
        if (byU[side].empty()) {
            for (std::uint32_t v = side == 0 ? 0 : m; v < (side == 0 ? m : m + n); ++v)
                byU[side].emplace_back(at(v).x, v);
            std::sort(byU[side].begin(), byU[side].end());
        }
        return byU[side];
    };
    // Steps around a contour of `count` points between two of its points.
    const auto steps = [](std::uint32_t a, std::uint32_t b, std::uint32_t count) {
        const std::uint32_t d = a > b ? a - b : b - a;
        return std::min(d, count - d);
    };
    // Whether the spanning edge from -> to reaches more than kBandOutOfRegister past the point of
    // the other contour nearest `from`, that point not beside `to` (a diagonal of a coarse band's quad
    // spans to the next point, a ray's spacing away). Only points within that reach can be it: a
    // window of u.
    const auto strays = [&](std::uint32_t from, std::uint32_t to) {
        const glm::dvec2 p = at(from);
        double reach = glm::distance(p, at(to)) - kBandOutOfRegister;
        if (reach <= 0.0) return false;
        const bool upperSide = to >= m;
        const auto& side = sorted(upperSide ? 1 : 0);
        std::int64_t nearest = -1;
        for (auto it = std::lower_bound(side.begin(), side.end(), std::pair{p.x - reach, std::uint32_t(0)});
             it != side.end() && it->first < p.x + reach; ++it) {
            const double d = glm::distance(p, at(it->second));
            if (d < reach) {
                reach = d;
                nearest = it->second;
            }
        }
        const std::uint32_t first = upperSide ? m : 0, count = upperSide ? n : m;
        return nearest >= 0 && steps(static_cast<std::uint32_t>(nearest) - first, to - first, count) > 1;
    };
    for (const Triangle& t : band)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t a = t[k], b = t[(k + 1) % 3];
            if ((a < m) != (b < m) && strays(a, b)) return true;
        }
    return false;
}

Reconstruction::Assembly::Side Reconstruction::Assembly::sideOf(std::size_t i) const
{
    return Side{members[i].contour, &strings[i], trees[i].get(), members[i].first};
}

// Band-local ids to the mesh's, turned outward.
void Reconstruction::Assembly::place(std::vector<Triangle>& band, const Side& lower, const Side& upper, bool flip)
{
    const std::uint32_t lowerCount = static_cast<std::uint32_t>(lower.contour->crossings.size());
    for (Triangle& t : band) {
        for (std::uint32_t& v : t) v = v < lowerCount ? lower.first + v : upper.first + (v - lowerCount);
        if (flip) std::swap(t[1], t[2]);
    }
}

// Bands: each member but a tube's first joins the one before it.
void Reconstruction::Assembly::tileBands()
{
    bandBytes.assign(members.size(), 0);
    bands.resize(members.size());
    std::vector<char> byArea(members.size(), 0);
    forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
        if (members[i].startsTube) return;
        if (walled[i - 1] || walled[i]) {
            bands[i] = tileRings(i);
            byArea[i] = 1;
            return;
        }
        bool area = false;
        bands[i] = tileSides(sideOf(i - 1), sideOf(i), bandBytes[i], area);
        byArea[i] = area ? 1 : 0;
        // A band the trees pair out of register goes to the area tiler. Where either contour has
        // extras (a patch's or a junction's vertices on its polygon), that tiler sees them too:
        // split in afterwards, they fan to the far corners of a long quad (the phantom sliced along
        // y: two contours a voxel apart, each with a patch's extras along a 36-pixel edge, fanned
        // across the quad's diagonal 1.53 voxels off the surface; 1.11 tiled with them).
        if (area && (!extras[i - 1].empty() || !extras[i].empty())) {
            bands[i] = tileRings(i);
            return;
        }
        place(bands[i], sideOf(i - 1), sideOf(i), members[i].tube->hole != mirrored);
        splitForExtras(bands[i], i - 1);
        splitForExtras(bands[i], i);
    });
    for (std::size_t bytes : bandBytes) result.tilingBytes += bytes;
    result.areaBands = static_cast<int>(std::count(byArea.begin(), byArea.end(), 1));
}

// The band to member i from the one before it over their rings, wall vertices and all, by the
// least-area tiler: the contour trees pair crossings alone.
std::vector<Triangle> Reconstruction::Assembly::tileRings(std::size_t i) const
{
    return tileByArea(ringOf(i - 1).ids, ringOf(i).ids, members[i].tube->hole != mirrored);
}

// The least-area surface between the closed chains of mesh vertices `lower` and `upper`, turned
// over where `flip` says.
std::vector<Triangle> Reconstruction::Assembly::tileByArea(const std::vector<std::uint32_t>& lower,
                                                           const std::vector<std::uint32_t>& upper, bool flip) const
{
    std::vector<glm::dvec3> lowerPoints, upperPoints;
    for (const std::uint32_t id : lower) lowerPoints.push_back(mesh.vertices[id]);
    for (const std::uint32_t id : upper) upperPoints.push_back(mesh.vertices[id]);
    std::vector<Triangle> band =
        withoutFullFans(tileLeastAreaNearest(lowerPoints, upperPoints), static_cast<std::uint32_t>(lower.size()),
                        static_cast<std::uint32_t>(upper.size()));
    for (Triangle& t : band) {
        for (std::uint32_t& v : t) v = v < lower.size() ? lower[v] : upper[v - lower.size()];
        if (flip) std::swap(t[1], t[2]);
    }
    return band;
}

ContourTree Reconstruction::Assembly::treeOf(std::size_t i) const
{
    return trees[i] ? *trees[i] : ContourTree(contourString(*members[i].contour));
}

// A star-shaped end contour fans around its apex; any other, or one without an apex, is
// closed flat by ear clipping, which follows C-shaped and folded sections.
// An end joined to a hole by an annulus (a hollow pipe's rim) is tiled as a band from the
// outer contour to the hole's, both counterclockwise: seen from the outer wall the band turns
// inward, so it faces +w, outward at the top. Where the hole lies around the wall (a cavity's
// floor around a post) it turns outward, so it faces -w at the top, as such a floor must. The
// hole's own end gets nothing. An end at a junction gets nothing either: the junction's
// triangles close it.
void Reconstruction::Assembly::emitCap(std::size_t self, bool top)
{
    const Member& m = members[self];
    const TubeEnd& end = top ? m.tube->top : m.tube->bottom;
    if (end.joined() || (m.tube->hole && end.annulus >= 0)) return;
    if (end.annulus >= 0) {
        const std::uint32_t count = static_cast<std::uint32_t>(m.contour->crossings.size());
        std::size_t hole = tubeFirst[end.annulus];
        if (top)
            while (!members[hole].endsTube) ++hole;
        std::vector<Triangle> annulus = tileBand(treeOf(self), treeOf(hole));
        for (Triangle& t : annulus) {
            for (std::uint32_t& v : t) v = v < count ? m.first + v : members[hole].first + (v - count);
            if (top == mirrored) std::swap(t[1], t[2]);
        }
        splitForExtras(annulus, self);
        splitForExtras(annulus, hole);
        mesh.triangles.insert(mesh.triangles.end(), annulus.begin(), annulus.end());
        return;
    }
    const Ring ring = ringOf(self);
    const std::uint32_t count = static_cast<std::uint32_t>(ring.ids.size());
    auto index = [&](std::uint32_t v) { return v < count ? ring.ids[v] : m.apex[top ? 1 : 0]; };
    // Ear clipping gives the plane's counterclockwise order, which faces outward at the top.
    bool flip = m.tube->hole != mirrored;
    std::vector<Triangle> cap;
    if (end.fan) {
        cap = tileCap(count, top);
    } else {
        cap = earClip(ring.points);
        flip = flip != !top;
    }
    for (Triangle t : cap) {
        for (std::uint32_t& v : t) v = index(v);
        if (flip) std::swap(t[1], t[2]);
        mesh.triangles.push_back(t);
    }
}

// Each tube in order: its bottom cap, its bands, its top cap.
void Reconstruction::Assembly::emitBandsAndCaps()
{
    std::size_t triangleCount = 0;
    for (const std::vector<Triangle>& band : bands) triangleCount += band.size();
    mesh.triangles.reserve(triangleCount + 2 * (vertexCount - static_cast<std::size_t>(result.crossings)) +
                           4 * mTubes.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
        if (members[i].startsTube) emitCap(i, false);
        mesh.triangles.insert(mesh.triangles.end(), bands[i].begin(), bands[i].end());
        if (members[i].endsTube) emitCap(i, true);
    }
}

// Junctions: each part is tiled to its partner. Where its polygon gave a contour, by the
// band, then the part's edges are split by the vertices on them (the single contour's own
// crossings and extras along an arc, the other parts' crossings along a shared chord, the
// nodes); else from all those vertices by the minimum-area tiler. Parts share each chord once
// in either direction, so the pieces join into one manifold with c - 2 saddles for c contours.
void Reconstruction::Assembly::tileJunction(std::size_t j)
{
    const Junction& junction = mJunctions[j];
    const Ring ring = ringOf(memberAt(junction.single));
    const Ring innerRing = junction.inner.first >= 0 ? ringOf(memberAt(junction.inner)) : Ring{};
    ChordVertices chords = onChord[j];
    for (auto& [chord, along] : chords) std::sort(along.begin(), along.end());
    for (std::size_t k = 0; k < junction.many.size(); ++k) tilePart(j, k, partBoundary(j, k, ring, innerRing, chords));
    if (junction.keyhole.open()) tileSlit(j, ring, innerRing, chords);
}

// A patch's triangles, as the cells gave them; each edge between two of its points on a loop
// fans through the ring's vertices between them (the loop's crossings and other extras).
void Reconstruction::Assembly::tilePatch(std::size_t p)
{
    const Patch& patch = mPatches[p];
    const std::vector<std::uint32_t>& id = patchIds[p];
    std::vector<Triangle> triangles;
    triangles.reserve(patch.surface.triangles.size());
    for (const auto& t : patch.surface.triangles) {
        triangles.push_back({id[t[0]], id[t[1]], id[t[2]]});
        if (mirrored) std::swap(triangles.back()[1], triangles.back()[2]);
    }
    // Per loop, its patch points (sorted, to be found in the ring: in ring order, consecutive ones
    // are an edge of the patch).
    std::map<std::pair<int, int>, std::vector<std::uint32_t>> pointsOn;
    for (std::size_t v = 0; v < patch.surface.vertices.size(); ++v) {
        const SlabPatch::Vertex& vertex = patch.surface.vertices[v];
        if (vertex.plane >= 0) pointsOn[{vertex.plane == 0 ? patch.below : patch.above, vertex.loop}].push_back(id[v]);
    }
    for (auto& [loop, ids] : pointsOn) {
        const Ring ring = ringOf(memberAt(loop));
        std::sort(ids.begin(), ids.end());
        std::vector<std::size_t> at; // ring positions of the patch's points
        for (std::size_t r = 0; r < ring.ids.size(); ++r)
            if (std::binary_search(ids.begin(), ids.end(), ring.ids[r])) at.push_back(r);
        PIPETILE_ASSERT(at.size() == ids.size(), "a patch's point is missing from its loop's ring");
        for (std::size_t k = 0; k < at.size(); ++k) {
            const std::size_t from = at[k], to = at[(k + 1) % at.size()];
            std::vector<std::uint32_t> between;
            for (std::size_t r = (from + 1) % ring.ids.size(); r != to; r = (r + 1) % ring.ids.size())
                between.push_back(ring.ids[r]);
            if (!between.empty()) splitEdge(triangles, ring.ids[from], ring.ids[to], between);
        }
    }
    mesh.triangles.insert(mesh.triangles.end(), triangles.begin(), triangles.end());
}

// A keyhole's slit: the quadrilateral of the ring's material between its two crossings, flat in
// the single contour's plane, where the gap its material closes ends (graph.h, Keyhole). Its
// boundary runs counterclockwise: along the wall's segment, back across the crossing to the
// hole, along the hole's segment backward, across the other crossing; it faces the partners.
void Reconstruction::Assembly::tileSlit(std::size_t j, const Ring& ring, const Ring& innerRing,
                                        const ChordVertices& chords)
{
    const Junction& junction = mJunctions[j];
    const Keyhole& keyhole = junction.keyhole;
    auto nodeOf = [&](int q) {
        const auto [member, point] = keyhole.at(q);
        return junction.nodeAt(member, point);
    };
    const int corners[4] = {nodeOf(keyhole.wallSize - 1), nodeOf(0), nodeOf(keyhole.size() - 1),
                            nodeOf(keyhole.wallSize)};
    std::vector<std::uint32_t> boundary;
    std::vector<glm::dvec2> points;
    // From node `from` up to node `to` (not included): along a ring, or across a crossing.
    auto walkRing = [&](const Ring& r, int from, int to, bool forward) {
        const std::size_t size = r.ids.size();
        const auto id = [&](int node) { return firstNodeOf[j] + static_cast<std::uint32_t>(node); };
        std::size_t p = static_cast<std::size_t>(std::find(r.ids.begin(), r.ids.end(), id(from)) - r.ids.begin());
        for (; r.ids[p] != id(to); p = (p + (forward ? 1 : size - 1)) % size) {
            boundary.push_back(r.ids[p]);
            points.push_back(r.points[p]);
        }
    };
    auto walkChord = [&](int from, int to) {
        boundary.push_back(firstNodeOf[j] + static_cast<std::uint32_t>(from));
        points.push_back(junction.nodePoints[from]);
        const Chord chord{std::min(from, to), std::max(from, to)};
        const auto along = chords.find(chord);
        if (along == chords.end()) return;
        std::vector<std::pair<double, std::uint32_t>> crossings = along->second;
        if (from > to) std::reverse(crossings.begin(), crossings.end());
        for (const auto& [t, id] : crossings) {
            boundary.push_back(id);
            points.push_back(glm::mix(junction.nodePoints[chord.first], junction.nodePoints[chord.second], t));
        }
    };
    walkRing(ring, corners[0], corners[1], true);
    walkChord(corners[1], corners[2]);
    walkRing(innerRing, corners[2], corners[3], false);
    walkChord(corners[3], corners[0]);
    // Counterclockwise in the plane faces +w: up at a fork, where the partners lie above.
    const bool flip = (junction.kind == EventKind::Fork) == mirrored;
    for (Triangle t : earClip(points)) {
        for (std::uint32_t& v : t) v = boundary[v];
        if (flip) std::swap(t[1], t[2]);
        mesh.triangles.push_back(t);
    }
}

// Part k's boundary: every vertex on it, in its order. Along an arc, the ring's entries from one
// cut to the next (as the bands split their edges); along a chord, the parts' crossings on it.
std::vector<std::uint32_t> Reconstruction::Assembly::partBoundary(std::size_t j, std::size_t k, const Ring& ring,
                                                                  const Ring& innerRing,
                                                                  const ChordVertices& chords) const
{
    const Junction& junction = mJunctions[j];
    const std::uint32_t firstNode = firstNodeOf[j];
    const std::vector<Junction::Part::Corner>& corners = junction.parts[k].corners;
    std::vector<std::uint32_t> boundary;
    for (std::size_t c = 0; c < corners.size();) {
        const Junction::Part::Corner &a = corners[c], &b = corners[(c + 1) % corners.size()];
        if (a.node >= 0) boundary.push_back(firstNode + static_cast<std::uint32_t>(a.node));
        const Ring& r = a.member == 1 ? innerRing : ring;
        const std::size_t size = r.ids.size();
        const int points = static_cast<int>(mLoops[(a.member == 1 ? junction.inner : junction.single).first]
                                                  [(a.member == 1 ? junction.inner : junction.single).second]
                                                      .view.polygon.size());
        const bool forward = b.point == (a.point + 1) % points, backward = a.point == (b.point + 1) % points;
        if (a.member >= 0 && a.member == b.member && (forward || backward)) {
            std::size_t end = c + 1;
            while (corners[end % corners.size()].node < 0) ++end;
            const std::uint32_t to = firstNode + static_cast<std::uint32_t>(corners[end % corners.size()].node);
            std::size_t p =
                static_cast<std::size_t>(std::find(r.ids.begin(), r.ids.end(), boundary.back()) - r.ids.begin());
            for (p = (p + (forward ? 1 : size - 1)) % size; r.ids[p] != to; p = (p + (forward ? 1 : size - 1)) % size)
                boundary.push_back(r.ids[p]);
            c = end;
            continue;
        }
        const auto along = chords.find({std::min(a.node, b.node), std::max(a.node, b.node)});
        if (along != chords.end()) {
            if (a.node < b.node)
                for (const auto& [t, id] : along->second) boundary.push_back(id);
            else
                for (auto e = along->second.rbegin(); e != along->second.rend(); ++e) boundary.push_back(e->second);
        }
        ++c;
    }
    return boundary;
}

// Tiles part k of junction j, whose boundary holds the vertices listed.
void Reconstruction::Assembly::tilePart(std::size_t j, std::size_t k, const std::vector<std::uint32_t>& boundary)
{
    const Junction& junction = mJunctions[j];
    const bool fork = junction.kind == EventKind::Fork, rim = junction.kind == EventKind::Rim;
    const std::size_t partner = memberAt(junction.many[k]);
    const bool partnerHole = mLoops[junction.many[k].first][junction.many[k].second].loop.hole();
    // A rim's face, from the wall's arc to its hole in one plane, faces +w at the top.
    const bool flip = rim ? junction.top == mirrored : partnerHole != mirrored;
    // Where the part's crossings lie in its boundary, from crossing 0's on; empty if they
    // are not all there in their order (a crossing at a cut, placed on the next arc).
    std::vector<std::size_t> at;
    if (!parts[j][k].crossings.empty()) {
        const std::uint32_t first = partFirst[j][k], count = static_cast<std::uint32_t>(parts[j][k].crossings.size());
        for (std::size_t e = 0; e < boundary.size(); ++e)
            if (boundary[e] >= first && boundary[e] < first + count) at.push_back(e);
        const auto start = std::find_if(at.begin(), at.end(), [&](std::size_t e) { return boundary[e] == first; });
        if (start != at.end()) std::rotate(at.begin(), start, at.end());
        for (std::uint32_t c = 0; c < at.size(); ++c)
            if (at.size() != count || boundary[at[c]] != first + c) at.clear();
    }
    std::vector<Triangle> triangles;
    if (!at.empty()) {
        const Contour& part = parts[j][k];
        ContourString string;
        std::unique_ptr<ContourTree> tree;
        if (mOptions.tiler == TilerKind::ContourTree) {
            string = contourString(part);
            tree = std::make_unique<ContourTree>(string);
        }
        const Side partSide{&part, &string, tree.get(), partFirst[j][k]}, partnerSide = sideOf(partner);
        const Side& lower = fork || rim ? partSide : partnerSide;
        const Side& upper = fork || rim ? partnerSide : partSide;
        std::size_t bytes = 0;
        bool byArea = false;
        triangles = tileSides(lower, upper, bytes, byArea);
        result.areaBands += byArea ? 1 : 0;
        result.tilingBytes += bytes;
        place(triangles, lower, upper, flip);
        // The part's edges, split by the vertices the boundary has between its crossings.
        for (std::size_t c = 0; c < at.size(); ++c) {
            const std::size_t next = at[(c + 1) % at.size()];
            std::vector<std::uint32_t> between;
            for (std::size_t e = (at[c] + 1) % boundary.size(); e != next; e = (e + 1) % boundary.size())
                between.push_back(boundary[e]);
            if (!between.empty()) splitEdge(triangles, boundary[at[c]], boundary[next], between);
        }
        splitForExtras(triangles, partner);
    } else {
        ++result.areaJunctionParts;
        const std::vector<std::uint32_t> partnerRing = ringOf(partner).ids;
        triangles = fork || rim ? tileByArea(boundary, partnerRing, flip) : tileByArea(partnerRing, boundary, flip);
    }
    mesh.triangles.insert(mesh.triangles.end(), triangles.begin(), triangles.end());
}

LevelMesh Reconstruction::Assembly::build(const std::vector<glm::dvec3>& coarser)
{
    addWallVertices(coarser);
    const Clock::time_point tiling = Clock::now();
    buildTrees();
    tileBands();
    result.tilingSeconds = secondsSince(tiling);
    emitBandsAndCaps();
    for (std::size_t j = 0; j < mJunctions.size(); ++j) tileJunction(j);
    for (std::size_t p = 0; p < mPatches.size(); ++p) tilePatch(p);
    // Vertices a hair apart make needles (collapseNeedleEdges), or triangles of no area where a
    // junction part's crossing falls on a vertex of the single contour: all but the coarser
    // level's go. The baselines stay as their papers give them (the optimal tiler's is the least
    // area): only copies of one point go, a millionth of a voxel apart (the aorta's shortest edge
    // is 5e-5 voxel).
    const Clock::time_point quality = Clock::now();
    const bool paper = mOptions.tiler == TilerKind::ContourTree;
    const double voxel = mVolume.smallestVoxel();
    // Below the top level every such edge goes whatever its triangles' shape: a level's vertices
    // stay at every finer level, where the same pair, no longer new, can make a needle no collapse
    // may take (the gaffer smoke's 232 at level 2, 0.05 voxel kept at level 1 under aspect 10).
    // A coarser level's rays lie about twice as far apart, and so may the ends of its edges that
    // go: each level below the next-to-top takes edges twice as long, up to four times
    // kNeedleEdgeVoxels. Over the evaluation's 59 runs its levels 0 and 1 kept a third and a fifth
    // fewer triangles, a quarter and three eighths as many under 5 degrees, as far from the
    // isosurface; its needles over 100 went from 63 to 52, and ring tree 0's 108 went, though
    // ring tree 1 sliced along x reaches 100.2 at levels 1 and 2 (Graph's known gap).
    // Edges within the top level's needle reach (kNeedleReachVoxels) that lie in a plane beside
    // one of the events' slabs, an eighth of a voxel thick, go too (ThinSlabPlanes): crossing tree
    // 1 sliced along x kept a needle of aspect 313 at level 2 over one of 0.24 voxel. That took
    // the evaluation's needles from 67 to 63 (65 with a quarter voxel; 62 with slabs a quarter
    // voxel thick too, but with needles grown elsewhere: 171 where a crop had 143).
    constexpr double kThinSlab = 0.125;
    const bool top = result.level == mOptions.levels - 1;
    const int coarsening = std::min(mOptions.levels - 1 - result.level, 3);
    const double shortEdge = (paper ? std::ldexp(kNeedleEdgeVoxels, std::max(coarsening - 1, 0)) : 1e-6) * voxel;
    ThinSlabPlanes thin{&mVolume, mPlan.axis, {}, kNeedleReachVoxels * voxel};
    for (std::size_t s = 0; s < mPositions.size(); ++s)
        if (thinnest[s] <= kThinSlab) thin.positions.push_back(mPositions[s]);
    std::sort(thin.positions.begin(), thin.positions.end());
    // The top level's collapses keep within its bound of the isosurface (a voxel), with a tenth of
    // a voxel to spare for the points between those the field is asked at. The corner removal
    // below does not: the tendrils' tips it tiles anew are thinner than the field's samples lie
    // apart, and with the bound 9 more levels of the evaluation kept a needle over 100.
    constexpr double kTopReach = 0.9;
    const SurfaceBound bound = top ? SurfaceBound{&mVolume, kTopReach} : SurfaceBound{};
    NeedleCollapse shortEdges;
    shortEdges.bound = bound;
    if (paper && !top)
        shortEdges.thin = &thin;
    else
        shortEdges.needleAspect = kShortEdgeAspect;
    collapseNeedleEdges(mesh, shortEdge, coarser, shortEdges);
    if (paper) {
        // The needles left, over longer edges where that lowers the worst aspect ratio around:
        // a coarser level's bands and sectors are about twice as long, and so are its needles'
        // short edges for one aspect ratio.
        // Below the top level, a needle's new corner may go along its other edges too: a patch's
        // wall, a vertex per pixel, facing a chord of 11.6 voxels across a slab an eighth of a
        // voxel thick leaves a needle whose own edges cannot go (its corner would turn a triangle
        // over) where a quarter-voxel edge beside it can (ring tree 1 sliced along x: 100.23 at
        // levels 1 and 2, now 49). Over the evaluation's 272 runs that took the levels with a
        // needle over 100 from 142 to 77, and levels 0 to 2 lost 2.3%, 1.3% and 1% of their
        // triangles for 2.6%, 2.3% and 1.5% more mean distance to the isosurface (the README's
        // triangle quality gives the outlier; measuring those collapses all over their triangles
        // took it back, for 2 more levels with a needle). At the top level too it took them to
        // 76, but it moved meshes by up to 0.4 voxel there (a Y sliced across its fork from 0.82
        // to 1.24 voxels off), so the top level keeps to the needles' own edges.
        const double reach = std::ldexp(kNeedleReachVoxels, coarsening) * voxel;
        NeedleCollapse needles;
        needles.needleAspect = kCollapseAspect;
        needles.lowerWorst = needles.measureMove = true;
        needles.alongCorners = !top;
        needles.bound = bound;
        collapseNeedleEdges(mesh, reach, coarser, needles);
        long long flips = flipNeedles(mesh, mVolume, mPlan.axis, coarser);
        result.flips = flips;
        // A flip lowers the worse of two triangles, and the better one it made can be a needle a
        // collapse now takes (the gaffer smoke's 118 at level 0): collapses and flips take turns
        // until either finds nothing. Each collapse removes a vertex, so the turns end.
        while (flips > 0 && collapseNeedleEdges(mesh, reach, coarser, needles) > 0) {
            flips = flipNeedles(mesh, mVolume, mPlan.axis, coarser);
            result.flips += flips;
        }
        // Below the top level the short edges go once more: the passes since can free one the
        // first could not take (the hollow Y's level 2 kept one of 0.094 voxel).
        if (!top && collapseNeedleEdges(mesh, shortEdge, coarser, shortEdges) > 0)
            result.flips += flipNeedles(mesh, mVolume, mPlan.axis, coarser);
        // What the collapses leave of a speck far thinner than a voxel can be a pillow of needles
        // (the smoke at iso 0.1 along y: aspect 541 at every level); it becomes a spindle.
        inflatePillows(mesh, mVolume, coarser);
        // The needles left lie at tendrils' tips and necks thinner than a tenth of a voxel, where
        // no collapse may go (it would pinch the surface) and no flip helps; their new corners go
        // and the holes are tiled anew. Twice the collapses' reach: a neck of three points in the
        // smoke at iso 0.1 along y moves its top level by 0.5 voxel (202 there; the top level's
        // distance to the isosurface stayed 0.99 voxel), and at the reach itself it stays.
        removeNeedleCorners(mesh, coarser, 2.0 * reach);
        // Until here no flip made a needle of three vertices the level below has (flipNeedles):
        // the needle it would replace could still go with its new corner. What is left may now
        // flip to the lower of the two.
        result.flips += flipNeedles(mesh, mVolume, mPlan.axis);
        // Needles whose corners all stay, that no flip lowers one at a time: a corner fanned over a
        // patch's wall (a vertex per pixel) nearly in line with it. Parts of the fans are tiled
        // anew, as far as the corners' removal may move the surface: over the evaluation's 80
        // runs that took the levels with a needle over 100 from 11 to 6 (the hollow Y and the Y
        // sliced along y have none now; the phantom sliced along y went from 13, 53 and 11 at
        // levels 1 to 3 to 1, 3 and 2), and changed nothing else.
        retileNeedleFans(mesh, 2.0 * reach, bound);
        // The passes since the collapses can leave short edges none of them looked at: three
        // points a thousandth of a voxel apart at a voxel's corner, the one the level below has
        // being a corner of only three triangles (a crop of the smoke: aspect 1697 at its top
        // level). They go where that lowers the worst aspect ratio around (63.7 there). Over the
        // evaluation's 81 runs, no distance to the isosurface and no largest aspect ratio moved,
        // and the top levels lost 0.25% of their triangles (0.6% of those under 5 degrees);
        // without the lowering, the smoke along z rose from 54 to 74 at its top level.
        NeedleCollapse lastEdges = shortEdges;
        lastEdges.lowerWorst = true;
        collapseNeedleEdges(mesh, shortEdge, coarser, lastEdges);
        // Last, at the top level only (a finer level would not have them where they went), the
        // needles' new corners move as little as they must: the smoke at iso 0.1 along x kept 154
        // on a void's bipyramid whose new ring vertex lay 0.006 voxel off its tips' line (91 now).
        // The needles left have their longest edge split, and the new vertex moves likewise: the
        // same void along z, whose short edge joins two vertices of the level below (174, now 90).
        if (top) {
            moveNeedleCorners(mesh, coarser, reach, bound);
            splitNeedleEdges(mesh, reach, bound);
        }
    }
    result.qualitySeconds = secondsSince(quality);
    return std::move(result);
}

namespace {

// Whether triangle t of `vertices` lies farther than `reach` voxels from the isosurface at its
// point farthest from its corners (which lie on the surface), as far as the field shows.
bool straysFrom(const Volume& volume, const std::vector<glm::dvec3>& vertices, const Triangle& t, double reach)
{
    const glm::dvec3 p = farthestFromCorners(vertices[t[0]], vertices[t[1]], vertices[t[2]]);
    // A flat surface within 0.88 of surfaceWithin's radius always shows: so does one within reach.
    return glm::distance(p, vertices[t[0]]) > reach * volume.smallestVoxel() && !volume.surfaceWithin(p, reach / 0.88);
}

// straysFrom, or at points `reach` apart over the triangle, outside the object: a band to an end
// contour fanned across a bay of its last contour lies farthest off beside the bay, not at the
// middle of its long sides (a crop of the smoke: 1.15 voxels off, though each triangle's point
// farthest from its corners was within a voxel), and no flip takes a fan. Inside the object the
// level's needle passes flip such slivers onto the surface (the crossing tubes sliced along y:
// end bands 1.16 voxels off as tiled, 0.45 at the top level), so only points outside are asked,
// unless `insideToo`: no flip takes a junction's fans (a crop: a merge of two walls and a hole in
// a slab half a voxel thick fanned a part 1.21 voxels deep into the object), nor a band's fan
// whose triangles are no needles (strayingBands).
// The points are asked within the reach itself, not over 0.88 as straysFrom asks: a surface a
// little past the reach shows there along some direction (another crop: an end band fanned across
// a valley 1.08 voxels off went unasked; so did two others, 1.04), and one within it that does not
// show only leaves the end to its cells (over crop survey seeds 115 to 120, 3 runs over a voxel
// went, and the evaluation's meshes stayed but for 16 triangles of one run).
bool straysAnywhere(const Volume& volume, const std::vector<glm::dvec3>& vertices, const Triangle& t, double reach,
                    bool insideToo = false)
{
    if (straysFrom(volume, vertices, t, reach)) return true;
    // Points `near` apart along the two edges from an end of the shortest edge: about as many as
    // the area takes. Steps of the longest edge's length along both edges took its square even on
    // a needle (the phantom sliced along y ran 44% longer, 2 s, once inside points were asked).
    int k = 0;
    for (int e = 1; e < 3; ++e)
        if (glm::distance(vertices[t[e]], vertices[t[(e + 1) % 3]]) <
            glm::distance(vertices[t[k]], vertices[t[(k + 1) % 3]]))
            k = e;
    const glm::dvec3 &a = vertices[t[k]], &b = vertices[t[(k + 1) % 3]], &c = vertices[t[(k + 2) % 3]];
    const double near = reach * volume.smallestVoxel();
    const int nb = std::max(1, static_cast<int>(std::ceil(glm::distance(a, b) / near)));
    const int nc = std::max(1, static_cast<int>(std::ceil(glm::distance(a, c) / near)));
    for (int i = 0; i <= nb; ++i)
        for (int j = 0; j * nb <= (nb - i) * nc; ++j) {
            const glm::dvec3 p = a + (b - a) * (double(i) / nb) + (c - a) * (double(j) / nc);
            if (std::min({glm::distance(p, a), glm::distance(p, b), glm::distance(p, c)}) > near &&
                (insideToo || volume.signedField(p) > 0.0) && !volume.surfaceWithin(p, reach))
                return true;
        }
    return false;
}

} // namespace

std::vector<bool> Reconstruction::Assembly::strayingJunctions(const std::vector<bool>& asked, double reach)
{
    if (trees.empty()) buildTrees();
    std::vector<bool> straying(mJunctions.size(), false);
    // At points all over each part, inside the object too (straysAnywhere), and at its corners:
    // the chords that split the single contour cross its inside, so their nodes need not lie on
    // the surface (a crop of the smoke at iso 0.1: a fork's chord node in its single contour's
    // plane lay 1.14 voxels inside, the partners' plane half a voxel above being inside there
    // too, and straysAnywhere asks no point within a voxel of a corner).
    const auto cornerStrays = [&](const Triangle& t) {
        return std::any_of(t.begin(), t.end(),
                           [&](std::uint32_t v) { return !mVolume.surfaceWithin(mesh.vertices[v], reach); });
    };
    for (std::size_t j = 0; j < mJunctions.size(); ++j) {
        if (!asked[j]) continue;
        const std::size_t first = mesh.triangles.size();
        tileJunction(j);
        straying[j] = std::any_of(mesh.triangles.begin() + static_cast<std::ptrdiff_t>(first), mesh.triangles.end(),
                                  [&](const Triangle& t) {
                                      return straysAnywhere(mVolume, mesh.vertices, t, reach, true) || cornerStrays(t);
                                  });
    }
    return straying;
}

std::set<std::pair<int, int>> Reconstruction::Assembly::strayingBands(const std::set<std::pair<int, int>>& asked,
                                                                      const std::set<std::pair<int, int>>& ends,
                                                                      double reach)
{
    if (walled.empty()) addWallVertices({}); // as build() tiles them, but for coarser levels' wall vertices
    if (trees.empty()) buildTrees();
    tileBands();
    // Inside the object too, but for bands to end contours (straysAnywhere): a band fanned from
    // one crossing across a vessel's inside to the crossings on a box's face has no needle for
    // the flips to take (a crop of the carotid sliced along x, in a slab an eighth of a voxel
    // thick: points of its triangles lay 1.26 voxels inside, the points farthest from their
    // corners within 0.82).
    std::set<std::pair<int, int>> straying;
    for (std::size_t i = 1; i < members.size(); ++i) {
        const std::pair<int, int> lower{members[i - 1].slice, members[i - 1].loop};
        if (members[i].startsTube || asked.count(lower) == 0) continue;
        const bool end = ends.count(lower) > 0;
        if (std::any_of(bands[i].begin(), bands[i].end(),
                        [&](const Triangle& t) { return straysAnywhere(mVolume, mesh.vertices, t, reach, !end); }))
            straying.insert(lower);
    }
    return straying;
}

bool Reconstruction::shapeMayStray(const SliceLoop& lower, const SliceLoop& upper)
{
    if (profileChange(lower.profile, upper.profile) > kShapeChange) return true;
    const double smaller = std::min(std::abs(lower.loop.area), std::abs(upper.loop.area));
    return glm::distance(lower.view.center, upper.view.center) > std::sqrt(smaller / M_PI);
}

bool Reconstruction::partsMayFan(const Junction& junction) const
{
    if (junction.kind == EventKind::Rim) return false;
    for (std::size_t k = 0; k < junction.parts.size(); ++k) {
        const Junction::Part& part = junction.parts[k];
        // A part not wound once around its partner's centre is tiled by the minimum-area tiler.
        if (part.view.winding != 1) return true;
        const SliceLoop& partner = mLoops[junction.many[k].first][junction.many[k].second];
        if (profileChange(radialProfile(part.view, profileDirections()), partner.profile) > kShapeChange) return true;
    }
    return false;
}

std::array<int, 3> Reconstruction::keyOf(const Junction& junction)
{
    return {static_cast<int>(junction.kind), junction.single.first, junction.single.second};
}

Reconstruction::StrayingPieces
Reconstruction::strayingPieces(const std::vector<std::pair<double, double>>& ranges) const
{
    StrayingPieces straying;
    if (mOptions.tiler != TilerKind::ContourTree) return straying;
    // The top level's bound, a voxel.
    constexpr double kStray = 1.0;
    const int top = mOptions.levels - 1;
    // A band lies in a slab of the graph, between its lower contour and the plane above, or in
    // part of one that a band's own planes split (splitBand): its cells are that slab's piece's.
    struct Slab {
        std::pair<int, int> lower;
        int above;
    };
    std::map<std::pair<int, int>, int> slabAbove; // a straying band's slab: its upper plane
    // The voxel planes around a slab: the range whose cells a band there takes instead.
    const auto voxelRange = [&](int lower, int above) {
        const double w0 = mPositions[static_cast<std::size_t>(lower)], w1 = mPositions[static_cast<std::size_t>(above)];
        return std::pair<double, double>{std::floor(std::min(w0, w1)), std::ceil(std::max(w0, w1))};
    };
    // A band from a tube's end contour to the graph's end member lies in no slab of the graph:
    // where it strays, the end is meshed from its cells (patchEnd) in the second build.
    std::map<std::pair<int, int>, std::array<int, 3>> endOfBand; // by the band's lower contour
    const auto strayed = [&](const Slab& slab) {
        if (const auto end = endOfBand.find(slab.lower); end != endOfBand.end()) {
            straying.ends.insert(end->second);
            return;
        }
        if (std::abs(mPositions[slab.above] - mPositions[slab.lower.first]) > kEventThickness) {
            straying.bands.insert(slab.lower);
            slabAbove[slab.lower] = slab.above;
        } else {
            straying.bandRanges.push_back(voxelRange(slab.lower.first, slab.above));
        }
    };
    // The bands that may stray, asked as the top level tiles them (only those, so a tube that
    // changes slowly costs nothing). Their own two contours tiled alone say little: they strayed
    // up to 4 voxels in the phantoms whose top levels keep within 0.96 (fold rays, extras and the
    // area tiler change them), and a U-bend's end band's did where the level's does not. Asked
    // from those, bands in slabs thicker than the events' took their cells needlessly, and the
    // cells met long band triangles in needles (the phantom sliced along y: 133 at level 2).
    std::map<std::pair<int, int>, Slab> levelBands;
    std::vector<bool> inGraph(mLoops.size(), false);
    for (const int s : mGraph.order) inGraph[static_cast<std::size_t>(s)] = true;
    for (const Tube& tube : mTubes) {
        std::vector<std::pair<int, int>> kept; // the members the top level keeps
        for (const auto& m : tube.members)
            if (mLoops[m.first][m.second].fromLevel <= top) kept.push_back(m);
        // Its end contours lie before its first member on the graph and after its last.
        const auto bottom = tube.members[graphEnd(tube, false)], topmost = tube.members[graphEnd(tube, true)];
        const std::size_t first = static_cast<std::size_t>(std::find(kept.begin(), kept.end(), bottom) - kept.begin());
        const std::size_t last = static_cast<std::size_t>(std::find(kept.begin(), kept.end(), topmost) - kept.begin());
        for (std::size_t k = 0; k < first && first < kept.size(); ++k)
            endOfBand[kept[k]] = {0, bottom.first, bottom.second};
        for (std::size_t k = last; k + 1 < kept.size(); ++k) endOfBand[kept[k]] = {1, topmost.first, topmost.second};
        std::size_t from = 0; // the member whose plane begins the graph's slab
        for (std::size_t k = 1; k < kept.size(); ++k) {
            const auto lower = kept[k - 1], upper = kept[k];
            if (inGraph[static_cast<std::size_t>(lower.first)]) from = k - 1;
            std::size_t to = k;
            while (to + 1 < kept.size() && !inGraph[static_cast<std::size_t>(kept[to].first)]) ++to;
            const Slab slab{kept[from], kept[to].first};
            const double w0 = mPositions[lower.first], w1 = mPositions[upper.first];
            if (!overlapsAny(ranges, std::min(w0, w1), std::max(w0, w1))) continue;
            const SliceLoop &below = mLoops[lower.first][lower.second], &above = mLoops[upper.first][upper.second];
            // A band whose shape changes, or near the bound in the graph's measure whose shape
            // keeps (splitBand).
            const bool mayStray = shapeMayStray(below, above) || mNearBands.count(lower) > 0;
            if (w1 != w0 && mayStray) levelBands.emplace(lower, slab);
        }
    }
    // The junctions whose parts may fan, as the top level tiles them.
    std::vector<bool> asked(mJunctions.size(), false);
    std::map<std::array<int, 3>, std::pair<double, double>> slabOf; // a straying junction's slab
    const auto slabOfJunction = [&](const Junction& junction) {
        std::pair<double, double> slab{mPositions[junction.single.first], mPositions[junction.single.first]};
        for (const auto& [plane, loop] : junction.many)
            slab = {std::min(slab.first, mPositions[plane]), std::max(slab.second, mPositions[plane])};
        return slab;
    };
    for (std::size_t j = 0; j < mJunctions.size(); ++j) {
        const auto [below, above] = slabOfJunction(mJunctions[j]);
        asked[j] = overlapsAny(ranges, below, above) && partsMayFan(mJunctions[j]);
    }
    const bool junctionsAsked = std::find(asked.begin(), asked.end(), true) != asked.end();
    Contours topContours; // the Assembly refers to them
    std::optional<Assembly> topLevel;
    if (junctionsAsked || !levelBands.empty()) {
        topContours = castLevel(top);
        topLevel.emplace(*this, topContours, top);
    }
    // Where a band strays in a slab as thin as the events', the whole range between the voxel
    // planes around it is meshed from its cells, where that keeps its pieces' count
    // (patchWholeRanges: a crop of the smoke, a band in a slab an eighth of a voxel thick fanned
    // across a bay 1.78 voxels off, its own cells closing with two handles too many). In part of
    // a thicker slab (splitBand), the slab's piece takes its cells, where they close. A band to an
    // end contour that strays leaves the end to its cells (patchEnd).
    if (!levelBands.empty()) {
        std::set<std::pair<int, int>> bands, ends;
        for (const auto& [band, slab] : levelBands) {
            bands.insert(band);
            if (endOfBand.count(slab.lower) > 0) ends.insert(band);
        }
        for (const std::pair<int, int>& band : topLevel->strayingBands(bands, ends, kStray))
            strayed(levelBands.at(band));
    }
    if (junctionsAsked) {
        const std::vector<bool> junctions = topLevel->strayingJunctions(asked, kStray);
        for (std::size_t j = 0; j < mJunctions.size(); ++j) {
            const Junction& junction = mJunctions[j];
            if (!junctions[j] || junction.kind == EventKind::Rim) continue;
            straying.junctions.insert(keyOf(junction));
            slabOf[keyOf(junction)] = slabOfJunction(junction);
        }
    }
    // Those whose cells would not close leave the skeleton as it is, but for a junction's slab:
    // halved down to an eighth of the events' thickness in the second build, its parts fan across
    // less (crops of the smoke: a merge whose small branch fanned to an arc of the single contour
    // 4 to 9 voxels away, its cells -5 against the piece's -3, 1.39 voxels off, now 0.94; a fork
    // whose parts fanned 4 voxels, -3 against -1, 2.02, now 0.71). Halved to a quarter, the first
    // was 1.13 off and the hollow Y sliced along y had needles up to 13 169; now 795 at its top
    // level (278 before), as its arms lie along the slices.
    for (auto it = straying.bands.begin(); it != straying.bands.end();) {
        if (cellsClose(it->first, it->second, true)) {
            ++it;
            continue;
        }
        straying.bandRanges.push_back(voxelRange(it->first, slabAbove[*it]));
        it = straying.bands.erase(it);
    }
    for (auto it = straying.junctions.begin(); it != straying.junctions.end();) {
        if (cellsClose((*it)[1], (*it)[2], (*it)[0] == static_cast<int>(EventKind::Fork))) {
            ++it;
            continue;
        }
        straying.thinJunctions.push_back(slabOf[*it]);
        it = straying.junctions.erase(it);
    }
    return straying;
}

LevelMesh Reconstruction::assemble(const Contours& contours, int level, const std::vector<glm::dvec3>& coarser) const
{
    return Assembly(*this, contours, level).build(coarser);
}

Reconstruction::~Reconstruction() = default;
Reconstruction::Reconstruction(const Reconstruction&) = default;
Reconstruction::Reconstruction(Reconstruction&&) noexcept = default;
Reconstruction& Reconstruction::operator=(const Reconstruction&) = default;
Reconstruction& Reconstruction::operator=(Reconstruction&&) noexcept = default;

Refinement::Refinement(const Reconstruction& reconstruction) : mReconstruction(&reconstruction)
{
    const Clock::time_point start = Clock::now();
    mContours = reconstruction.castLevel(0);
    const double casting = secondsSince(start);
    mMesh = reconstruction.assemble(mContours, 0, {});
    mMesh.castingSeconds = casting;
    mMesh.seconds = secondsSince(start);
}

const LevelMesh& Refinement::refine()
{
    if (!canRefine())
        throw UsageError("cannot refine past level " + std::to_string(mLevel) + ": the reconstruction has " +
                         std::to_string(mReconstruction->levelCount()) + " levels");
    const Clock::time_point start = Clock::now();
    mContours = mReconstruction->refineContours(mContours, mLevel + 1);
    const double casting = secondsSince(start);
    ++mLevel;
    mMesh = mReconstruction->assemble(mContours, mLevel, mMesh.mesh.vertices);
    mMesh.castingSeconds = casting;
    mMesh.seconds = secondsSince(start);
    return mMesh;
}

} // namespace pipetile
