// Meshes a sphere held in a dense array through the installed headers and library, and checks that
// the mesh is closed with the Euler characteristic of a sphere. Exit 0 when it is.

#include <pipetile/pipetile.h>

#include <cmath>
#include <cstdio>
#include <vector>

int main()
{
    // A level set of a sphere of radius 6 voxels in a 20^3 block: distance to the surface.
    const int n = 20;
    std::vector<float> distance(static_cast<std::size_t>(n) * n * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                distance[(static_cast<std::size_t>(i) * n + j) * n + k] = static_cast<float>(
                    std::sqrt((i - 9.5) * (i - 9.5) + (j - 9.5) * (j - 9.5) + (k - 9.5) * (k - 9.5)) - 6.0);
    pipetile::DenseVolume dense;
    dense.values = distance.data();
    dense.dims = glm::ivec3(n);
    try {
        const pipetile::Volume volume = pipetile::volumeFromDense(dense, {}, "consumer sphere");
        pipetile::MeshOptions options;
        options.levels = 2;
        const pipetile::Reconstruction reconstruction(volume, options);
        const pipetile::LevelMesh level = reconstruction.buildLevel(1);
        const pipetile::Topology topology = pipetile::checkTopology(level.mesh);
        std::printf("consumer: %zu vertices, %zu triangles, closed %d, Euler characteristic %lld\n",
                    level.mesh.vertices.size(), level.mesh.triangles.size(), topology.closed() ? 1 : 0, topology.euler);
        // A sphere: closed, one component, V - E + F = 2.
        return topology.closed() && topology.components == 1 && topology.euler == 2 ? 0 : 1;
    } catch (const pipetile::Error& e) {
        std::fprintf(stderr, "consumer: %s\n", e.what());
        return 1;
    }
}
