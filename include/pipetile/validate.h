// pipetile — validate: checks of a mesh on its own (topology, quality) and against the isosurface of
// the volume it came from (openvdb::tools::volumeToMesh, adaptivity 0, quads split).
#pragma once

#include <pipetile/graph.h>
#include <pipetile/mesh_io.h>
#include <pipetile/volume.h>

#include <array>
#include <memory>
#include <vector>

namespace pipetile {

/// Combinatorial checks of a triangle mesh; integer logic except the enclosed volume.
struct Topology {
    long long vertices = 0; // referenced by some triangle
    long long edges = 0;
    long long triangles = 0;
    long long boundaryEdges = 0;                           // edges with one triangle
    long long nonManifoldEdges = 0;                        // edges with three or more triangles
    long long nonManifoldVertices = 0;                     // vertices whose triangles do not form one fan
    long long misorientedEdges = 0;                        // edges whose two triangles run the same way along them
    std::array<long long, 2> firstNonManifoldEdge{-1, -1}; // the lowest-numbered one's vertices; -1: none
    long long firstNonManifoldVertex = -1;                 // the lowest-numbered one; -1: none
    int components = 0;                                    // connected by shared edges
    long long euler = 0;                                   // V - E + F
    double signedVolume = 0.0;                             // world units^3; > 0 when closed and normals point outward
    bool closed() const { return boundaryEdges == 0; }
    bool manifold() const { return nonManifoldEdges == 0 && nonManifoldVertices == 0; }
    bool oriented() const { return misorientedEdges == 0; }
    bool outward() const { return signedVolume > 0.0; }
};

/// Precondition: every triangle names vertices of the mesh (readMesh and the library's own meshes
/// guarantee it; check a mesh from elsewhere first).
Topology checkTopology(const TriangleMesh& mesh);

/// Distance statistics, world units. Mean and RMS are weighted by the surface area each sample
/// stands for; the maximum also covers every vertex.
struct DistanceStats {
    double max = 0.0;
    double mean = 0.0;
    double rms = 0.0;
    long long samples = 0;
};

/// Shape of the triangles.
struct TriangleQuality {
    double area = 0.0;          // world units^2
    double smallestAngle = 0.0; // degrees, over non-degenerate triangles
    double largestAspect = 0.0; // longest edge / shortest altitude * sqrt(3)/2: 1 for equilateral
    long long degenerate = 0;   // area below 1e-12 of the longest edge squared
    long long needles = 0;      // triangles with an angle below kNeedleDegrees (5), degenerate
                                // ones included
};

/// Precondition as checkTopology.
TriangleQuality measureQuality(const TriangleMesh& mesh);

/// Points on a mesh standing for its surface: every vertex (weight 0), and the centroids of a
/// regular subdivision of each triangle into k^2 parts, k = ceil(max(sqrt(2 area), longest edge
/// / 4) / spacing), each weighted by its part's area (about one sample per spacing^2). Deterministic.
struct SurfaceSamples {
    std::vector<glm::dvec3> points;
    std::vector<double> weights;
};
SurfaceSamples sampleSurface(const TriangleMesh& mesh, double spacing);

/// |signed field| of a level set at every vertex: the level set's own distance to its surface.
/// @throw Error if the volume is not a level set (a fog value is no distance).
DistanceStats levelSetDistanceAtVertices(const Volume& volume, const TriangleMesh& mesh);

/// Everything `pipetile validate` reports about one mesh. Distances in world units; divide by
/// `voxel` (the smallest voxel edge) for voxels.
struct Validation {
    double voxel = 1.0;
    DistanceStats meshToReference; // from samples of the mesh to the reference isosurface
    DistanceStats referenceToMesh; // from samples of the reference to the mesh
    DistanceStats symmetric;       // max of both maxima; area-weighted mean and RMS of both
    bool hasLevelSet = false;
    DistanceStats levelSet; // |level set| at the mesh samples (level sets only)
    Topology topology;
    TriangleQuality quality;
    double referenceArea = 0.0, referenceVolume = 0.0; // of the isosurface
    long long referenceTriangles = 0;
    double referenceSeconds = 0.0;      // volumeToMesh and quad splitting, this run
    double seconds = 0.0;               // this validation, reference excluded
    std::vector<double> vertexDistance; // per mesh vertex, distance to the reference
};

struct ValidationOptions {
    double sampleSpacingVoxels = 1.0; // face samples about this far apart, in voxels: at least one
                                      // per voxel-sized isosurface triangle, several per long one
    int threads = 0;                  // 0: all cores; results do not depend on it
};

/// Stateful: meshes the volume's isosurface once (volumeToMesh, adaptivity 0, quads split) and
/// indexes it, then validates any number of meshes against it.
class Validator {
public:
    /// Keeps its own copy of the volume handle (the grid is shared), so `volume` need not outlive it.
    explicit Validator(const Volume& volume, const ValidationOptions& options = {});
    ~Validator();
    Validator(const Validator&) = delete;
    Validator& operator=(const Validator&) = delete;

    /// The mesh must be in the volume's world space, and its triangles name its own vertices.
    /// @throw Error if the mesh has no triangles.
    Validation validate(const TriangleMesh& mesh) const;

    const TriangleMesh& reference() const;
    double referenceSeconds() const;

private:
    struct Impl;
    std::unique_ptr<Impl> mImpl;
};

/// openvdb::tools::volumeToMesh of the volume at its isovalue, quads split into triangles, in
/// world space; `seconds` receives the time it took.
TriangleMesh isosurface(const Volume& volume, double adaptivity, double* seconds = nullptr);

/// The Euler characteristic of that isosurface at adaptivity 0, counted from the grid's cells with
/// volumeToMesh's own tables, without building the mesh: a vertex per edge group of a cell (its
/// signs corrected across an ambiguous face as volumeToMesh corrects them), an edge per distinct
/// pair of groups across a face, a face per grid edge that crosses the iso value. Exact, and a
/// fraction of volumeToMesh's time: the contour graph's sum is checked against it (handles at the
/// voxel scale, which the slabs' labelling does not count).
long long isosurfaceEuler(const Volume& volume);

/// The same count along the index axis `axis` (0, 1, 2: x, y, z), layer by layer (graph.h's
/// EulerProfile): compared plane by plane with the contour graph's own sums, it says where a missed
/// handle lies, and buildContourGraph adds planes there.
EulerProfile isosurfaceEulerProfile(const Volume& volume, int axis);

/// Whether a region on one side of the isovalue (a speck, or a void: voxels as volumeToMesh sees
/// them, 6-connected) could lie wholly between two of `planes` (index w along the index axis
/// `axis`, increasing), or beyond the first or the last, where no plane meets it and no slab's
/// pieces show it; the cells then tell (buildContourGraph). False guarantees that none does. A
/// fraction of the cells' time: a look at each voxel of the leaves, a walk along the runs that
/// start between planes, and a search around those that end before the next.
bool regionBetweenPlanes(const Volume& volume, int axis, const std::vector<double>& planes);

/// Where the contour graph's Euler characteristic parts from the isosurface's: both summed from
/// below up to each voxel plane of the graph (the graph's from its pieces, the isosurface's from
/// `profile`, along the graph's axis), and past the last plane. Each change of their difference
/// from one such plane to the next is listed, with the two planes (index w; infinite past the first
/// or last). The differences add up to the isosurface's Euler characteristic less the graph's. A
/// difference of -2 is a handle of the isosurface that no slab piece shows; a change undone at the
/// next plane is a critical point that the two place on either side of a plane.
struct EulerDifference {
    double wBelow = 0.0, wAbove = 0.0;
    long long difference = 0;
};
std::vector<EulerDifference> eulerDifferences(const EulerProfile& profile, const ContourGraph& graph,
                                              const std::vector<double>& planeW);

/// Colours for a per-vertex error: blue at 0, through green and yellow, to red at `redAt` and
/// beyond (world units). For a PLY a user can open in any viewer.
std::vector<glm::dvec3> errorColors(const std::vector<double>& distances, double redAt);

} // namespace pipetile
