// pipetile — `pipetile bench`: every figure is measured in this run, on the same grid, as the median
// of several repetitions (DESIGN.md, Measuring).

#include "bench.h"
#include "html_report.h"
#include "report.h"

#include <pipetile/pipetile.h>

#include "phantoms.h"

#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <optional>

namespace pipetile::tools {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct Timing {
    double median = 0.0, min = 0.0, max = 0.0;
};

// Median and spread of a set of timings.
Timing summarize(std::vector<double> seconds)
{
    std::sort(seconds.begin(), seconds.end());
    return {seconds[seconds.size() / 2], seconds.front(), seconds.back()};
}

// Runs `work` once to warm up, then `repeat` times timed; its last result is kept by the caller
// through the closure.
Timing measure(int repeat, const std::function<void()>& work)
{
    // One run first, untimed, for every method alike: first-touch page faults, the thread pool
    // starting and cold caches belong to no method.
    work();
    std::vector<double> seconds;
    for (int r = 0; r < repeat; ++r) {
        const Clock::time_point start = Clock::now();
        work();
        seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
    }
    return summarize(std::move(seconds));
}

// Runs `a` and `b` alternately, `repeat` times each after one untimed run of each: a ratio of
// their medians then compares them under the same machine load, which drifts between figures
// measured one after the other.
std::pair<Timing, Timing> measurePair(int repeat, const std::function<void()>& a, const std::function<void()>& b)
{
    a();
    b();
    std::vector<double> sa, sb;
    for (int r = 0; r < repeat; ++r) {
        for (auto [work, seconds] : {std::pair{&a, &sa}, std::pair{&b, &sb}}) {
            const Clock::time_point start = Clock::now();
            (*work)();
            seconds->push_back(std::chrono::duration<double>(Clock::now() - start).count());
        }
    }
    return {summarize(std::move(sa)), summarize(std::move(sb))};
}

json timingJson(const Timing& t)
{
    return {{"seconds", t.median}, {"min", t.min}, {"max", t.max}};
}

// uniform volumeToMesh followed by meshoptimizer, down to `targetTriangles`.
TriangleMesh simplified(const TriangleMesh& mesh, std::size_t targetTriangles)
{
    std::vector<unsigned int> indices;
    indices.reserve(3 * mesh.triangles.size());
    for (const Triangle& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
    std::vector<float> positions;
    positions.reserve(3 * mesh.vertices.size());
    for (const glm::dvec3& p : mesh.vertices) {
        positions.push_back(static_cast<float>(p.x));
        positions.push_back(static_cast<float>(p.y));
        positions.push_back(static_cast<float>(p.z));
    }
    std::vector<unsigned int> out(indices.size());
    // target_error 1 (relative to the mesh extent): let the triangle count decide, as a user
    // asking for "this many triangles" would. A level finer than the uniform isosurface (a thin
    // vessel's top level) asks for more than there is: the uniform mesh then stays whole (the
    // simplifier refuses a target above its input).
    const std::size_t target = std::min(3 * targetTriangles, indices.size());
    const std::size_t count = meshopt_simplify(out.data(), indices.data(), indices.size(), positions.data(),
                                               mesh.vertices.size(), 3 * sizeof(float), target, 1.0f, 0, nullptr);
    TriangleMesh result;
    result.vertices = mesh.vertices;
    for (std::size_t i = 0; i + 2 < count; i += 3) result.triangles.push_back({out[i], out[i + 1], out[i + 2]});
    return result;
}

json accuracyJson(const Validation& v)
{
    return {{"hausdorff_voxels", v.symmetric.max / v.voxel},
            {"rms_voxels", v.symmetric.rms / v.voxel},
            {"closed", v.topology.closed()},
            {"manifold", v.topology.manifold()}};
}

} // namespace

int runBench(const BenchArgs& args)
{
    if (args.repeat < 1 || args.repeat > 1000) throw UsageError("--repeat must be between 1 and 1000");
    // Locked before the (long) measurements, so a concurrent bench writing the same report fails now.
    std::optional<OutputSet> outputs;
    std::vector<std::string> targets;
    for (const std::string& target : {args.report, args.html})
        if (!target.empty()) targets.push_back(target);
    if (!targets.empty()) outputs.emplace(targets, args.owner);
    const Volume volume = args.input.empty() ? samples::makeSample("phantom") : readVolume(args.input);
    const int repeat = args.repeat;
    MeshOptions options;
    options.threads = args.threads;
    json report = {{"input", volume.source()}, {"grid", volume.gridName()}, {"repeat", repeat}};
    std::printf("# pipetile bench: %s, grid '%s' (median of %d runs; min..max in the JSON)\n\n",
                volume.source().c_str(), pipetile::printableName(volume.gridName()).c_str(), repeat);

    // The whole pipeline, all levels, as `pipetile mesh` runs it (files aside).
    std::vector<LevelMesh> levels;
    const Timing pipeline = measure(repeat, [&] {
        const Reconstruction r(volume, options);
        Refinement refinement(r);
        levels.assign(1, refinement.mesh());
        while (refinement.canRefine()) levels.push_back(refinement.refine());
    });

    // Table 1: the same contours tiled by each tiler (only the tiling is timed), on every slice as
    // in the paper, so that triangles double from level to level.
    std::printf("## Table 1: tilers on the same contours (area and smallest angle: the whole mesh)\n\n"
                "| level | rays | tiler | seconds | triangles | bytes | area | smallest angle "
                "|\n|---|---|---|---|---|---|---|---|\n");
    json table1 = json::array();
    const std::vector<std::pair<TilerKind, const char*>> tilers = {
        {TilerKind::ContourTree, "contour-tree"}, {TilerKind::Optimal, "optimal"}, {TilerKind::Greedy, "greedy"}};
    std::vector<std::unique_ptr<Reconstruction>> byTiler;
    for (const auto& [kind, name] : tilers) {
        MeshOptions o = options;
        o.tiler = kind;
        o.everySlice = true;
        byTiler.push_back(std::make_unique<Reconstruction>(volume, o));
    }
    for (int level = 0; level < options.levels; ++level) {
        json row = {{"level", level + 1}, {"rays", options.baseRays << level}};
        for (std::size_t k = 0; k < tilers.size(); ++k) {
            std::vector<double> seconds;
            LevelMesh m;
            for (int r = 0; r < repeat; ++r) {
                m = byTiler[k]->buildLevel(level);
                seconds.push_back(m.tilingSeconds);
            }
            const Timing t = summarize(std::move(seconds));
            const TriangleQuality q = measureQuality(m.mesh);
            json cell = timingJson(t);
            cell.update({{"triangles", m.mesh.triangles.size()},
                         {"bytes", m.tilingBytes},
                         {"area", q.area},
                         {"smallest_angle", q.smallestAngle}});
            row[tilers[k].second] = cell;
            std::printf("| %d | %d | %s | %.5f | %zu | %zu | %.1f | %.2f |\n", level + 1, options.baseRays << level,
                        tilers[k].second, t.median, m.mesh.triangles.size(), m.tilingBytes, q.area, q.smallestAngle);
        }
        table1.push_back(row);
    }
    report["table1"] = table1;

    // Refinement (paper §4.3): level L+1 refined from level L against built from scratch.
    {
        MeshOptions o = options;
        o.levels = options.levels + 1;
        const Reconstruction r(volume, o);
        std::printf("\n## Refinement: L -> L+1 against L+1 from scratch\n\n"
                    "| L | refine (s) | of which new rays (s) | scratch (s) | refine / scratch | refine / new rays |\n"
                    "|---|---|---|---|---|---|\n");
        json rows = json::array();
        for (int level = 0; level + 1 < o.levels; ++level) {
            std::vector<double> refine, casting, scratch;
            for (int k = 0; k < repeat; ++k) {
                Refinement refinement(r);
                while (refinement.level() < level) refinement.refine();
                const LevelMesh& refined = refinement.refine();
                refine.push_back(refined.seconds);
                casting.push_back(refined.castingSeconds);
                scratch.push_back(r.buildLevel(level + 1).seconds);
            }
            const Timing refineTime = summarize(refine), scratchTime = summarize(scratch);
            const double a = refineTime.median, c = summarize(casting).median, b = scratchTime.median;
            rows.push_back({{"from", level},
                            {"refine_seconds", a},
                            {"new_rays_seconds", c},
                            {"scratch_seconds", b},
                            {"ratio", a / b},
                            {"refine_per_new_rays", a / c},
                            {"refine_min", refineTime.min},
                            {"refine_max", refineTime.max},
                            {"scratch_min", scratchTime.min},
                            {"scratch_max", scratchTime.max}});
            std::printf("| %d | %.5f | %.5f | %.5f | %.2f | %.2f |\n", level, a, c, b, a / b, a / c);
        }
        report["refinement"] = rows;
    }

    // Peers on the same grid: volumeToMesh uniform and adaptive, and uniform + meshoptimizer. Each
    // is timed alternately with the whole pipeline, and compared with that pairing's median.
    auto runPipeline = [&] {
        const Reconstruction r(volume, options);
        Refinement refinement(r);
        while (refinement.canRefine()) refinement.refine();
    };
    const Validator validator(volume, {1.0, args.threads});
    std::printf("\n## Peers (distances to the uniform isosurface, in voxels)\n\n"
                "| method | seconds | triangles | Hausdorff | RMS | pipetile, all levels, alternating (s) | "
                "time vs pipetile |\n|---|---|---|---|---|---|---|\n");
    json peers = json::array();
    auto peerRow = [&](const std::string& name, const Timing& t, const Timing& paired,
                       const TriangleMesh& mesh) -> Validation {
        const Validation v = validator.validate(mesh);
        json row = {{"method", name}, {"triangles", mesh.triangles.size()}};
        row.update(timingJson(t));
        row.update(accuracyJson(v));
        row["pipetile_paired_seconds"] = paired.median;
        row["ratio_to_pipetile"] = t.median / paired.median;
        peers.push_back(row);
        std::printf("| %s | %.4f | %zu | %.3f | %.3f | %.4f | %.1fx |\n", name.c_str(), t.median, mesh.triangles.size(),
                    v.symmetric.max / v.voxel, v.symmetric.rms / v.voxel, paired.median, t.median / paired.median);
        return v;
    };
    auto peer = [&](const std::string& name, const std::function<TriangleMesh()>& make) {
        TriangleMesh mesh;
        const auto [paired, t] = measurePair(repeat, runPipeline, [&] { mesh = make(); });
        peerRow(name, t, paired, mesh);
    };
    peer("volumeToMesh uniform", [&] { return isosurface(volume, 0.0); });
    for (double adaptivity : {0.3, 0.6, 0.9})
        peer("volumeToMesh adaptive " + std::to_string(adaptivity).substr(0, 3),
             [&, adaptivity] { return isosurface(volume, adaptivity); });
    for (const LevelMesh& level : levels)
        peer("uniform + meshopt_simplify to L" + std::to_string(level.level),
             [&] { return simplified(isosurface(volume, 0.0), level.mesh.triangles.size()); });
    // pipetile's levels nested over one vertex array, the same meshes renumbered, for the page's .glb.
    const NestedLevels nested = nestLevels(levels);
    tools::HtmlReport html;
    GlbOptions glb;
    for (std::size_t k = 0; k < levels.size(); ++k) {
        const LevelMesh& level = levels[k];
        Timing t{level.seconds, level.seconds, level.seconds};
        const Validation v = peerRow("pipetile L" + std::to_string(level.level) + " (level alone)", t, pipeline,
                                     tools::nestedMesh(nested, k));
        json row = levelReport(level, /*topology=*/true);
        row["validation"] = validationReport(v);
        html.levels.push_back(row);
        glb.vertexError = v.vertexDistance; // the finest level's, at the end: every vertex of the array
        html.voxel = v.voxel;
    }
    {
        // What skipping slices buys: the same levels on every slice, as the paper builds them.
        MeshOptions o = options;
        o.everySlice = true;
        const Reconstruction r(volume, o);
        for (int level = 0; level < o.levels; ++level) {
            const LevelMesh m = r.buildLevel(level);
            const Timing t{m.seconds, m.seconds, m.seconds};
            peerRow("pipetile L" + std::to_string(level) + ", every slice (level alone)", t, pipeline, m.mesh);
        }
    }
    report["peers"] = peers;
    report["pipetile"] = timingJson(pipeline);
    std::printf("\npipetile mesh, all %d levels: %.4f s (min %.4f, max %.4f)\n", options.levels, pipeline.median,
                pipeline.min, pipeline.max);
    if (!args.report.empty())
        outputs->write(args.report, [&](std::ostream& out) { out << reportText(report, 2) << '\n'; });
    if (!args.html.empty()) {
        html.title = "pipetile bench: " + volume.source();
        html.subtitle = "grid '" + pipetile::printableName(volume.gridName()) + "', median of " +
                        std::to_string(repeat) + " runs; distances to the uniform isosurface";
        html.peers = peers;
        tools::writeHtmlReport(*outputs, args.html, html, nested, glb);
    }
    if (outputs) outputs->commit();
    return 0;
}

} // namespace pipetile::tools
