// Micro-benchmarks of the tilers on one contour pair of n crossings each (DESIGN.md, Measuring):
// the integer contour-tree band against the toroidal baselines on the same pair sizes.

#include <pipetile/tiler.h>
#include <pipetile/toroidal.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

namespace {

constexpr double pi = 3.14159265358979323846;

// n points counterclockwise seen from +z. B is A turned by 0.1 rad and widened by 10%, so the
// minimal surface is not the index-to-index pairing and greedy has real choices to make.
std::vector<glm::dvec3> circle(std::size_t n, double radius, double z, double phase)
{
    std::vector<glm::dvec3> points;
    points.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double angle = phase + 2.0 * pi * static_cast<double>(i) / static_cast<double>(n);
        points.push_back({radius * std::cos(angle), radius * std::sin(angle), z});
    }
    return points;
}

void BM_TileBand(benchmark::State& state)
{
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    const std::vector<pipetile::EdgeType> star(n, pipetile::EdgeType::Forward);
    for (auto _ : state) benchmark::DoNotOptimize(pipetile::tileBand(star, star));
    state.SetComplexityN(state.range(0));
    // tileBand reports no working memory: only the 2n triangles it returns are counted here, not
    // the two contour trees it builds.
    state.counters["bytes"] = static_cast<double>(2 * n * sizeof(pipetile::Triangle));
}

template <auto Tiler>
void BM_Toroidal(benchmark::State& state)
{
    const std::size_t n = static_cast<std::size_t>(state.range(0));
    const auto a = circle(n, 10.0, 0.0, 0.0), b = circle(n, 11.0, 1.0, 0.1);
    pipetile::ToroidalStats stats;
    for (auto _ : state) benchmark::DoNotOptimize(Tiler(a, b, &stats));
    state.SetComplexityN(state.range(0));
    state.counters["bytes"] = static_cast<double>(stats.bytes);
}

void BM_TileOptimal(benchmark::State& state)
{
    BM_Toroidal<pipetile::tileOptimal>(state);
}
void BM_TileGreedy(benchmark::State& state)
{
    BM_Toroidal<pipetile::tileGreedy>(state);
}

} // namespace

BENCHMARK(BM_TileBand)->RangeMultiplier(2)->Range(8, 1024)->Complexity(benchmark::oN);
// n starts searched by bisection, each over a band of the n x n graph: O(n^2 log n).
BENCHMARK(BM_TileOptimal)->RangeMultiplier(2)->Range(8, 1024)->Complexity([](benchmark::IterationCount n) {
    return static_cast<double>(n) * static_cast<double>(n) * std::log2(static_cast<double>(n));
});
BENCHMARK(BM_TileGreedy)->RangeMultiplier(2)->Range(8, 1024)->Complexity(benchmark::oN);
