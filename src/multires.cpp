// pipetile — multires: levels of detail, from a volume to closed triangle meshes.

#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/toroidal.h>

#include <glm/geometric.hpp>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <cmath>
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

// Runs `body(i)` for i in [0, count) on `threads` threads (0: all cores). Each index writes only
// its own results, so the output never depends on the thread count.
template <class Body>
void forEachIndex(int threads, std::size_t count, const Body& body)
{
    auto run = [&] { tbb::parallel_for(std::size_t(0), count, [&](std::size_t i) { body(i); }); };
    if (threads == 0) return run(); // the default arena: creating one per call costs more than small loops
    tbb::task_arena arena(threads);
    arena.execute(run);
}

// Where the tube really ends, beyond its last slice: march from the central point along the
// slicing axis until the field turns outside, then bisect. Cone-shaped caps then follow rounded
// ends instead of cutting them flat at the last slice.
bool findApex(const SlicePlane& plane, const glm::dvec2& center, double direction, double reach, double& wApex)
{
    constexpr double kStep = 0.25;
    const double w0 = plane.w();
    double inT = 0.0;
    if (plane.sampleAt(center, w0) >= 0.0) return false;
    for (double t = kStep; t <= reach + 1e-9; t += kStep) {
        if (plane.sampleAt(center, w0 + direction * t) >= 0.0) {
            double lo = inT, hi = t;
            for (int i = 0; i < 40; ++i) {
                const double mid = 0.5 * (lo + hi);
                (plane.sampleAt(center, w0 + direction * mid) < 0.0 ? lo : hi) = mid;
            }
            wApex = w0 + direction * 0.5 * (lo + hi);
            return true;
        }
        inT = t;
    }
    return false;
}

// Index in [0, count) of the candidate that `accept` takes whose point is nearest `target` (the
// first of equals); -1 if it takes none.
template <class PointOf, class Accept>
int nearest(int count, const glm::dvec2& target, const PointOf& pointOf, const Accept& accept)
{
    int best = -1;
    double bestDistance2 = 0.0;
    for (int k = 0; k < count; ++k) {
        if (!accept(k)) continue;
        const glm::dvec2 d = pointOf(k) - target;
        const double distance2 = d.x * d.x + d.y * d.y;
        if (best < 0 || distance2 < bestDistance2) { best = k; bestDistance2 = distance2; }
    }
    return best;
}

// Triangulates a simple polygon, counterclockwise in the plane, by ear clipping: m - 2 triangles,
// counterclockwise. Where rounding leaves no clean ear (a nearly degenerate polygon), the most
// convex corner is clipped anyway, so the count, and the closed mesh, never depend on it.
std::vector<Triangle> earClip(const std::vector<glm::dvec2>& p)
{
    std::vector<std::uint32_t> ring(p.size());
    for (std::uint32_t i = 0; i < ring.size(); ++i) ring[i] = i;
    auto cross = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        const glm::dvec2 u = p[b] - p[a], v = p[c] - p[b];
        return u.x * v.y - u.y * v.x;
    };
    auto inside = [&](std::uint32_t q, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        return cross(a, b, q) >= 0.0 && cross(b, c, q) >= 0.0 && cross(c, a, q) >= 0.0;
    };
    std::vector<Triangle> triangles;
    while (ring.size() > 3) {
        const std::size_t n = ring.size();
        std::size_t clip = n, convexmost = 0;
        double best = -std::numeric_limits<double>::infinity();
        for (std::size_t k = 0; k < n && clip == n; ++k) {
            const std::uint32_t a = ring[(k + n - 1) % n], b = ring[k], c = ring[(k + 1) % n];
            const double turn = cross(a, b, c);
            if (turn > best) { best = turn; convexmost = k; }
            if (turn <= 0.0) continue;
            bool ear = true;
            for (std::size_t j = 0; j < n && ear; ++j) {
                const std::uint32_t q = ring[j];
                if (q != a && q != b && q != c && inside(q, a, b, c)) ear = false;
            }
            if (ear) clip = k;
        }
        if (clip == n) clip = convexmost;
        triangles.push_back({ring[(clip + n - 1) % n], ring[clip], ring[(clip + 1) % n]});
        ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(clip));
    }
    if (ring.size() == 3) triangles.push_back({ring[0], ring[1], ring[2]});
    return triangles;
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

} // namespace

void checkMeshOptions(const MeshOptions& options)
{
    if (options.baseRays < 3 || options.baseRays > 4096)
        throw UsageError("--rays must be between 3 and 4096 (got " + std::to_string(options.baseRays) +
                         "); with fewer than 3 rays forward and backward edges cannot be told apart");
    if (options.levels < 1 || options.levels > 16)
        throw UsageError("--levels must be between 1 and 16 (got " + std::to_string(options.levels) + ")");
    const long long finest = static_cast<long long>(options.baseRays) << (options.levels - 1);
    if (finest > 65536)
        throw UsageError("--rays " + std::to_string(options.baseRays) + " with --levels " +
                         std::to_string(options.levels) + " asks for " + std::to_string(finest) +
                         " rays per contour at the top level; the limit is 65536: lower --rays or --levels");
    if (!(options.minContourArea >= 0.0) || !std::isfinite(options.minContourArea))
        throw UsageError("the minimum contour area must be a finite number >= 0");
    if (options.threads < 0) throw UsageError("--threads must be 0 (all cores) or more");
}

Reconstruction::Reconstruction(const Volume& volume, const MeshOptions& options)
    : mVolume(volume), mOptions(options)
{
    const Clock::time_point start = Clock::now();
    checkMeshOptions(options);
    mPlan = planSlices(volume, options.slicing);
    const std::size_t sliceCount = mPlan.positions.size();
    mStats.slices = static_cast<int>(sliceCount);

    struct SliceCounts { int small = 0, unwound = 0; };
    std::vector<SliceCounts> counts(sliceCount);
    mLoops.assign(sliceCount, {});
    forEachIndex(options.threads, sliceCount, [&](std::size_t s) {
        const SlicePlane plane(mVolume, mPlan, mPlan.positions[s]);
        for (BoundaryLoop& loop : traceBoundaries(plane)) {
            if (std::abs(loop.area) < options.minContourArea) { ++counts[s].small; continue; }
            LoopView view = viewFrom(loop, centralPoint(loop));
            if (view.winding != 1) {
                ++counts[s].unwound;
                continue;
            }
            mLoops[s].push_back({std::move(loop), std::move(view)});
        }
    });
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
        throw Error("'" + volume.source() + "', grid '" + volume.gridName() + "': no slice crosses the surface at iso " +
                    std::to_string(volume.iso()) + " (" + std::to_string(sliceCount) +
                    " slices); the object is thinner than the slice spacing: lower --spacing");

    // Correspondence: a contour continues the contour of the previous slice of the same kind
    // (wall or hole) whose region holds its centre, or holds the other's; the nearest centres
    // pair first, one to one. A contour with no partner starts a new tube.
    std::vector<int> tubeOf;
    for (std::size_t s = 0; s < sliceCount; ++s) {
        std::vector<int> next(mLoops[s].size(), -1);
        if (s > 0) {
            struct Candidate { double distance2; int previous, current; };
            std::vector<Candidate> candidates;
            for (int i = 0; i < static_cast<int>(mLoops[s - 1].size()); ++i)
                for (int j = 0; j < static_cast<int>(mLoops[s].size()); ++j) {
                    const SliceLoop& a = mLoops[s - 1][i];
                    const SliceLoop& b = mLoops[s][j];
                    if (a.loop.hole() != b.loop.hole()) continue;
                    if (!encloses(a.loop, b.view.center) && !encloses(b.loop, a.view.center)) continue;
                    const glm::dvec2 d = a.view.center - b.view.center;
                    candidates.push_back({d.x * d.x + d.y * d.y, i, j});
                }
            std::stable_sort(candidates.begin(), candidates.end(),
                             [](const Candidate& p, const Candidate& q) { return p.distance2 < q.distance2; });
            std::vector<bool> taken(mLoops[s - 1].size(), false);
            for (const Candidate& c : candidates) {
                if (taken[c.previous] || next[c.current] >= 0) continue;
                taken[c.previous] = true;
                next[c.current] = tubeOf[c.previous];
            }
        }
        for (int j = 0; j < static_cast<int>(mLoops[s].size()); ++j) {
            if (next[j] < 0) {
                next[j] = static_cast<int>(mTubes.size());
                mTubes.push_back({});
                mTubes.back().hole = mLoops[s][j].loop.hole();
            }
            mTubes[next[j]].members.push_back({static_cast<int>(s), j});
        }
        tubeOf = std::move(next);
    }
    // Tube ends. Tubes were created in slice order, and their members are in slice order too.
    // Where the axis through the end contour's central point leaves the object, an end contour
    // a quarter voxel inside that point is added, so caps sit within a quarter voxel of flat ends
    // and follow rounded ones; the apex is then sought again from it. (Closer in, the field's
    // rounding at the rim of a flat end shrinks the end contour: the bean's top level is 0.75
    // voxels off with 0.1, 0.53 with 0.25, 0.62 with 0.5.)
    mPositions = mPlan.positions;
    const double reach = options.slicing.spacingVoxels + 2.0;
    constexpr double kEndInset = 0.25;
    for (Tube& tube : mTubes) {
        for (const bool top : {false, true}) {
            const double direction = top ? 1.0 : -1.0;
            const auto [s, l] = top ? tube.members.back() : tube.members.front();
            const SliceLoop& member = mLoops[s][l];
            const SlicePlane plane(mVolume, mPlan, mPositions[s]);
            double wApex = plane.w();
            TubeEnd& end = top ? tube.top : tube.bottom;
            end.hasApex = !tube.hole && findApex(plane, member.view.center, direction, reach, wApex);
            end.apexIndex = planeToIndex(mPlan.axis, member.view.center, wApex);
            const double wEnd = wApex - direction * kEndInset;
            if (!end.hasApex || direction * (wEnd - plane.w()) < 0.25) continue;
            const SlicePlane endPlane(mVolume, mPlan, wEnd);
            std::vector<BoundaryLoop> loops = traceBoundaries(endPlane);
            const int best = nearest(
                static_cast<int>(loops.size()), member.view.center, [&](int k) { return loops[k].centroid; },
                [&](int k) {
                    const BoundaryLoop& candidate = loops[k];
                    return !candidate.hole() && std::abs(candidate.area) >= options.minContourArea &&
                           (encloses(candidate, member.view.center) || encloses(member.loop, candidate.centroid));
                });
            if (best < 0) continue;
            const glm::dvec2 center = centralPoint(loops[best]);
            LoopView view = viewFrom(loops[best], center);
            if (view.winding != 1) continue;
            mPositions.push_back(wEnd);
            mLoops.push_back({});
            mLoops.back().push_back({std::move(loops[best]), std::move(view)});
            const std::pair<int, int> added{static_cast<int>(mPositions.size()) - 1, 0};
            if (top) tube.members.push_back(added);
            else tube.members.insert(tube.members.begin(), added);
            ++mStats.endContours;
            double wAgain = wEnd;
            end.hasApex = findApex(endPlane, center, direction, 2.0 * kEndInset + 1.0, wAgain);
            end.apexIndex = planeToIndex(mPlan.axis, center, wAgain);
        }
    }
    // One cap style for every level, so that levels nest: an apex fan where the end contour is
    // star-shaped with the finest rays (a ray crossing it more than once would at every finer
    // level too), ear clipping otherwise.
    const RaySet finest{options.baseRays, options.levels - 1};
    for (Tube& tube : mTubes) {
        for (const bool top : {false, true}) {
            TubeEnd& end = top ? tube.top : tube.bottom;
            if (!end.hasApex) continue;
            const auto [s, l] = top ? tube.members.back() : tube.members.front();
            const SlicePlane plane(mVolume, mPlan, mPositions[s]);
            const Contour c = castRays(mLoops[s][l].view, finest, plane);
            end.fan = !c.crossings.empty() && countEdges(c, EdgeType::Forward) == static_cast<int>(c.edges.size());
        }
    }
    // A lone contour closed flat on both sides would get the same triangles twice: it encloses
    // nothing, so it is dropped (and counted) rather than meshed as a flat pillow.
    const auto pillow = [](const Tube& t) { return t.members.size() == 1 && !t.bottom.fan && !t.top.fan; };
    mStats.droppedFlat = static_cast<int>(std::count_if(mTubes.begin(), mTubes.end(), pillow));
    mTubes.erase(std::remove_if(mTubes.begin(), mTubes.end(), pillow), mTubes.end());
    if (mTubes.empty())
        throw Error("'" + volume.source() + "', grid '" + volume.gridName() +
                    "': every cross-section lies in a single slice and cannot be closed; lower --spacing");
    // Hollow pipes: where a hole tube ends in the same plane as the outer tube around it, the two
    // end contours are joined by an annulus, the pipe's rim, instead of closing each wall by a
    // cap of its own (two caps over the hollow, far from any surface). Nearest hole first.
    for (int h = 0; h < static_cast<int>(mTubes.size()); ++h) {
        if (!mTubes[h].hole) continue;
        for (const bool top : {false, true}) {
            const std::pair<int, int> holeEnd = top ? mTubes[h].members.back() : mTubes[h].members.front();
            const int hs = holeEnd.first, hl = holeEnd.second; // named, not bound: lambdas below use them
            const glm::dvec2 holeCenter = mLoops[hs][hl].view.center;
            auto endLoop = [&](int o) -> const SliceLoop& {
                const auto [os, ol] = top ? mTubes[o].members.back() : mTubes[o].members.front();
                return mLoops[os][ol];
            };
            const int best = nearest(
                static_cast<int>(mTubes.size()), holeCenter, [&](int o) { return endLoop(o).view.center; },
                [&](int o) {
                    const Tube& outer = mTubes[o];
                    const TubeEnd& end = top ? outer.top : outer.bottom;
                    const int os = (top ? outer.members.back() : outer.members.front()).first;
                    return !outer.hole && !end.hasApex && end.annulus < 0 && os == hs &&
                           encloses(endLoop(o).loop, holeCenter);
                });
            if (best < 0) continue;
            (top ? mTubes[best].top : mTubes[best].bottom).annulus = h;
            (top ? mTubes[h].top : mTubes[h].bottom).annulus = best;
            ++mStats.annularCaps;
            addRimContours(mTubes[best], mTubes[h], top, reach, kEndInset);
        }
    }
    // Ray groups: a tube, joined with the tubes an annulus ties it to (their end contours are
    // tiled together, so they must share their rays).
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
    chooseSlices();
    for (const Tube& tube : mTubes)
        for (const TubeEnd* end : {&tube.bottom, &tube.top}) {
            if (end->annulus >= 0) continue;
            mStats.flatCaps += end->hasApex ? 0 : 1;
            mStats.clippedCaps += end->fan ? 0 : 1;
        }
    mStats.slices = static_cast<int>(mPlan.positions.size());
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
        throw UsageError("--rays " + std::to_string(options.baseRays) + " with --levels " + std::to_string(options.levels) +
                         " would need about " + std::to_string(static_cast<long long>(crossings * kBytesPerCrossing / (1 << 30))) +
                         " GiB for the finest level (" + std::to_string(mStats.contours) + " contours); lower --levels");
    mStats.seconds = secondsSince(start);
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
    const int directions =
        static_cast<int>(std::min(static_cast<long long>(mOptions.baseRays) << (mOptions.levels - 1), 256LL));
    struct Profile {
        std::vector<glm::dvec2> points; // per direction: nearest, farthest
        double radius = 0.0;            // the farthest crossing
    };
    std::vector<glm::dvec2> unit(directions);
    for (int d = 0; d < directions; ++d) unit[d] = {std::cos(2.0 * kPi * d / directions), std::sin(2.0 * kPi * d / directions)};
    std::vector<std::vector<Profile>> profiles(mLoops.size());
    forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
        profiles[s].resize(mLoops[s].size());
        for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
            const SliceLoop& loop = mLoops[s][l];
            if (loop.group < 0) continue;
            const RadialProfile radial = radialProfile(loop.view, directions);
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
                if (!(worst <= coarsest * coarsest)) return 0; // level 0 must split (NaN: a direction
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

void Reconstruction::addRimContours(Tube& outer, Tube& hole, bool top, double reach, double inset)
{
    // Where the wall itself ends: from a point in the middle of the wall (halfway from a point of
    // the hole's loop to the nearest point of the outer loop), along the slicing axis.
    const double direction = top ? 1.0 : -1.0;
    const auto [s, ol] = top ? outer.members.back() : outer.members.front();
    const int hl = (top ? hole.members.back() : hole.members.front()).second;
    const BoundaryLoop& outerLoop = mLoops[s][ol].loop;
    const BoundaryLoop& holeLoop = mLoops[s][hl].loop;
    if (outerLoop.points.empty() || holeLoop.points.empty()) return;
    const glm::dvec2 h = holeLoop.points.front();
    glm::dvec2 o = outerLoop.points.front();
    for (const glm::dvec2& p : outerLoop.points)
        if (glm::dot(p - h, p - h) < glm::dot(o - h, o - h)) o = p;
    const glm::dvec2 wall = 0.5 * (h + o);
    const SlicePlane plane(mVolume, mPlan, mPositions[s]);
    double wEnd = plane.w();
    if (!findApex(plane, wall, direction, reach, wEnd)) return;
    wEnd -= direction * inset;
    if (direction * (wEnd - plane.w()) < 0.25) return;
    // The two walls' loops on that plane: the outer one around the hole's centre, and the hole
    // nearest to it; both must still wind once around their central points.
    const SlicePlane endPlane(mVolume, mPlan, wEnd);
    std::vector<BoundaryLoop> loops = traceBoundaries(endPlane);
    const glm::dvec2 holeCenter = mLoops[s][hl].view.center;
    auto nearestAround = [&](bool holeLoop) {
        return nearest(static_cast<int>(loops.size()), holeCenter, [&](int k) { return loops[k].centroid; }, [&](int k) {
            return loops[k].hole() == holeLoop && std::abs(loops[k].area) >= mOptions.minContourArea &&
                   encloses(loops[k], holeCenter);
        });
    };
    const int bestOuter = nearestAround(false), bestHole = nearestAround(true);
    if (bestOuter < 0 || bestHole < 0) return;
    LoopView outerView = viewFrom(loops[bestOuter], centralPoint(loops[bestOuter]));
    LoopView holeView = viewFrom(loops[bestHole], centralPoint(loops[bestHole]));
    if (outerView.winding != 1 || holeView.winding != 1) return;
    mPositions.push_back(wEnd);
    mLoops.push_back({});
    mLoops.back().push_back({std::move(loops[bestOuter]), std::move(outerView)});
    mLoops.back().push_back({std::move(loops[bestHole]), std::move(holeView)});
    const int plane2 = static_cast<int>(mPositions.size()) - 1;
    for (const auto& [tube, loop] : {std::pair<Tube*, int>{&outer, 0}, std::pair<Tube*, int>{&hole, 1}}) {
        if (top) tube->members.push_back({plane2, loop});
        else tube->members.insert(tube->members.begin(), {plane2, loop});
    }
    mStats.endContours += 2;
}

int Reconstruction::finestUsefulLevel() const
{
    for (int level = 0; level < mOptions.levels; ++level)
        if ((static_cast<long long>(mOptions.baseRays) << level) > mStats.longestBoundary) return std::max(level - 1, 0);
    return mOptions.levels - 1;
}

LevelMesh Reconstruction::buildLevel(int level) const
{
    if (level < 0 || level >= mOptions.levels)
        throw UsageError("level " + std::to_string(level) + " is outside 0.." + std::to_string(mOptions.levels - 1));
    const Clock::time_point start = Clock::now();
    const Contours contours = castLevel(level);
    const double casting = secondsSince(start);
    LevelMesh result = assemble(contours, level);
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
            contours[s].push_back(l.fromLevel <= level ? castRays(l.view, rays, plane) : Contour{});
    });
    addFoldRays(contours);
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
            if (mLoops[s][l].group >= 0 && !coarse[s][l].crossings.empty()) groupRays[mLoops[s][l].group] = &coarse[s][l].rays;
    Contours contours(mLoops.size());
    forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
        if (mLoops[s].empty()) return;
        const SlicePlane plane(mVolume, mPlan, mPositions[s]);
        for (std::size_t l = 0; l < mLoops[s].size(); ++l) {
            const SliceLoop& loop = mLoops[s][l];
            if (!coarse[s][l].crossings.empty())
                contours[s].push_back(refineContour(coarse[s][l], loop.view, plane));
            else if (loop.fromLevel <= level)
                contours[s].push_back(castRays(loop.view, groupRays[loop.group]->next(), plane));
            else
                contours[s].emplace_back();
        }
    });
    addFoldRays(contours);
    return contours;
}

void Reconstruction::addFoldRays(Contours& contours) const
{
    // Half a voxel: a smooth tube's top level stays well within it (the phantom's is 0.16 voxel
    // from the isosurface), so a fold chord farther than that from its boundary stands out.
    constexpr double kFoldTolerance = 0.5;
    const std::size_t groups = mTubes.size(); // group ids are tube indices
    for (int round = 0; round <= RaySet::kFoldDepth; ++round) {
        std::vector<std::vector<std::vector<int>>> flagged(mLoops.size()); // per plane, per loop
        forEachIndex(mOptions.threads, mLoops.size(), [&](std::size_t s) {
            for (std::size_t l = 0; l < mLoops[s].size(); ++l)
                if (mLoops[s][l].group >= 0 && !contours[s][l].crossings.empty())
                    flagged[s].push_back(hiddenFolds(contours[s][l], mLoops[s][l].view, kFoldTolerance));
                else
                    flagged[s].emplace_back();
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
                    contours[s][l] = refineContour(contours[s][l], mLoops[s][l].view, grown[g], plane);
            }
        });
    }
}

LevelMesh Reconstruction::assemble(const Contours& contours, int level) const
{
    const RaySet rays{mOptions.baseRays, level};
    LevelMesh result;
    result.level = level;
    result.rays = rays.count();
    TriangleMesh& mesh = result.mesh;
    const bool mirrored = mVolume.mirrored();

    // Every contour of every tube in tube order, with the index of its first vertex. A fan cap's
    // apex follows the first (or last) contour of its tube. Contours, trees and bands are then
    // built in parallel and joined in this order, so the mesh does not depend on the threads.
    struct Member {
        const Tube* tube;
        bool startsTube, endsTube; // the tube's first and last contour (at every level: ends are kept)
        const Contour* contour;
        int slice;
        std::uint32_t first;  // index of its first vertex
        std::uint32_t apex[2]; // bottom, top cap apex (members that end a tube with a fan)
    };
    std::vector<Member> members;
    std::vector<std::size_t> tubeFirst(mTubes.size()); // index in `members` of each tube's first
    std::uint32_t vertexCount = 0;
    for (const Tube& tube : mTubes) {
        tubeFirst[&tube - mTubes.data()] = members.size();
        for (std::size_t k = 0; k < tube.members.size(); ++k) {
            const auto [s, l] = tube.members[k];
            if (mLoops[s][l].fromLevel > level) {
                ++result.skippedContours;
                continue;
            }
            const bool startsTube = k == 0, endsTube = k + 1 == tube.members.size();
            const Contour& c = contours[s][l];
            if (c.crossings.empty() || countEdges(c, EdgeType::Forward) - countEdges(c, EdgeType::Backward) != c.rays.count() ||
                c.rays.count() != contours[tube.members[0].first][tube.members[0].second].rays.count())
                throw std::logic_error("pipetile internal invariant broken: a contour does not wind once (#F - #B != n), or "
                                       "differs in rays from its tube");
            if (startsTube) result.addedRays += c.rays.count() - rays.count();
            ++result.contours;
            result.ambiguousContours += isUnambiguous(c) ? 0 : 1;
            result.interpolationFallbacks += c.interpolationFallbacks;
            result.crossings += static_cast<long long>(c.crossings.size());
            Member member{&tube, startsTube, endsTube, &c, s, vertexCount, {0, 0}};
            vertexCount += static_cast<std::uint32_t>(c.crossings.size());
            if (startsTube && tube.bottom.fan) member.apex[0] = vertexCount++;
            if (endsTube && tube.top.fan) member.apex[1] = vertexCount++;
            members.push_back(member);
        }
    }
    mesh.vertices.resize(vertexCount);
    forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
        const Member& m = members[i];
        for (std::size_t j = 0; j < m.contour->crossings.size(); ++j)
            mesh.vertices[m.first + j] =
                mVolume.indexToWorld(planeToIndex(mPlan.axis, m.contour->crossings[j].point, mPositions[m.slice]));
        if (m.startsTube && m.tube->bottom.fan) mesh.vertices[m.apex[0]] = mVolume.indexToWorld(m.tube->bottom.apexIndex);
        if (m.endsTube && m.tube->top.fan)
            mesh.vertices[m.apex[1]] = mVolume.indexToWorld(m.tube->top.apexIndex);
    });

    // Contour trees, one per contour; where a sector is ambiguous, each band ranks its two
    // contours against each other (rule [1'], below), so the trees may differ from band to band.
    const Clock::time_point tiling = Clock::now();
    std::vector<std::unique_ptr<ContourTree>> trees(members.size());
    std::vector<ContourString> strings(members.size());
    std::vector<std::size_t> bandBytes(members.size(), 0);
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
    // Bands: each member but a tube's first joins the one before it, with vertex indices of both.
    std::vector<std::vector<Triangle>> bands(members.size());
    forEachIndex(mOptions.threads, members.size(), [&](std::size_t i) {
        const Member& m = members[i];
        if (m.startsTube) return;
        const Member& previous = members[i - 1];
        const std::uint32_t previousCount = static_cast<std::uint32_t>(previous.contour->crossings.size());
        std::vector<Triangle>& band = bands[i];
        if (mOptions.tiler == TilerKind::ContourTree) {
            // Rule [1'] per band: the lower contour keeps in each ambiguous sector the F edge
            // closest to the upper contour's, then the upper one the F edge closest to that
            // choice. Ranking each contour once, against the contour below it only, carried a
            // choice made for one band into the next, where the upper contour's sector can hold
            // the other F edge (bean: the arm tip grows past a ray between two slices) and the
            // traversal then paired the tip with the hole's wall.
            const ContourTree* lower = trees[i - 1].get();
            const ContourTree* upper = trees[i].get();
            std::unique_ptr<ContourTree> rankedLower, rankedUpper;
            if (lower->ambiguousSectors() > 0) {
                rankedLower = std::make_unique<ContourTree>(
                    strings[i - 1], rankAgainstNeighbour(*previous.contour, strings[i - 1], *m.contour, *upper));
                lower = rankedLower.get();
                bandBytes[i] += lower->bytes();
            }
            if (upper->ambiguousSectors() > 0) {
                rankedUpper = std::make_unique<ContourTree>(
                    strings[i], rankAgainstNeighbour(*m.contour, strings[i], *previous.contour, *lower));
                upper = rankedUpper.get();
                bandBytes[i] += upper->bytes();
            }
            band = tileBand(*lower, *upper);
        } else {
            // The baselines see the same contours as world-space points.
            const auto first = mesh.vertices.begin();
            const std::vector<glm::dvec3> a(first + previous.first, first + previous.first + previousCount);
            const std::vector<glm::dvec3> b(first + m.first, first + m.first + m.contour->crossings.size());
            ToroidalStats stats;
            band = mOptions.tiler == TilerKind::Optimal ? tileOptimal(a, b, &stats) : tileGreedy(a, b, &stats);
            bandBytes[i] = stats.bytes;
        }
        // Band-local indices: the previous contour's vertices, then this one's.
        const bool flip = m.tube->hole != mirrored;
        for (Triangle& t : band) {
            for (std::uint32_t& v : t) v = v < previousCount ? previous.first + v : m.first + (v - previousCount);
            if (flip) std::swap(t[1], t[2]);
        }
    });
    result.tilingSeconds = secondsSince(tiling);
    for (std::size_t bytes : bandBytes) result.tilingBytes += bytes;

    // A star-shaped end contour fans around its apex; any other, or one without an apex, is
    // closed flat by ear clipping, which follows C-shaped and folded sections.
    // An end joined to a hole by an annulus (a hollow pipe's rim) is tiled as a band from the
    // outer contour to the hole's, both counterclockwise: seen from the outer wall the band turns
    // inward, so it faces +w, outward at the top. The hole's own end gets nothing.
    auto treeOf = [&](std::size_t i) {
        return trees[i] ? *trees[i] : ContourTree(contourString(*members[i].contour));
    };
    auto emitCap = [&](std::size_t self, bool top) {
        const Member& m = members[self];
        const TubeEnd& end = top ? m.tube->top : m.tube->bottom;
        if (m.tube->hole && end.annulus >= 0) return;
        const std::uint32_t count = static_cast<std::uint32_t>(m.contour->crossings.size());
        if (end.annulus >= 0) {
            std::size_t hole = tubeFirst[end.annulus];
            if (top)
                while (!members[hole].endsTube) ++hole;
            for (Triangle t : tileBand(treeOf(self), treeOf(hole))) {
                for (std::uint32_t& v : t) v = v < count ? m.first + v : members[hole].first + (v - count);
                if (top == mirrored) std::swap(t[1], t[2]);
                mesh.triangles.push_back(t);
            }
            return;
        }
        auto index = [&](std::uint32_t v) { return v < count ? m.first + v : m.apex[top ? 1 : 0]; };
        // Ear clipping gives the plane's counterclockwise order, which faces outward at the top.
        bool flip = m.tube->hole != mirrored;
        std::vector<Triangle> cap;
        if (end.fan) {
            cap = tileCap(count, top);
        } else {
            std::vector<glm::dvec2> polygon;
            for (const Crossing& x : m.contour->crossings) polygon.push_back(x.point);
            cap = earClip(polygon);
            flip = flip != !top;
        }
        for (Triangle t : cap) {
            for (std::uint32_t& v : t) v = index(v);
            if (flip) std::swap(t[1], t[2]);
            mesh.triangles.push_back(t);
        }
    };
    std::size_t triangleCount = 0;
    for (const std::vector<Triangle>& band : bands) triangleCount += band.size();
    mesh.triangles.reserve(triangleCount + 2 * (vertexCount - static_cast<std::size_t>(result.crossings)) +
                           4 * mTubes.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
        if (members[i].startsTube) emitCap(i, false);
        mesh.triangles.insert(mesh.triangles.end(), bands[i].begin(), bands[i].end());
        if (members[i].endsTube) emitCap(i, true);
    }
    return result;
}

Refinement::Refinement(const Reconstruction& reconstruction) : mReconstruction(&reconstruction)
{
    const Clock::time_point start = Clock::now();
    mContours = reconstruction.castLevel(0);
    const double casting = secondsSince(start);
    mMesh = reconstruction.assemble(mContours, 0);
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
    mMesh = mReconstruction->assemble(mContours, mLevel);
    mMesh.castingSeconds = casting;
    mMesh.seconds = secondsSince(start);
    return mMesh;
}

} // namespace pipetile
