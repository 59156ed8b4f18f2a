// pipetile — validate: checks of a mesh on its own (topology) and against the volume it came from.
#pragma once

#include <pipetile/mesh_io.h>
#include <pipetile/volume.h>

namespace pipetile {

/// Combinatorial checks of a triangle mesh; integer logic except the enclosed volume.
struct Topology {
    long long vertices = 0;        // referenced by some triangle
    long long edges = 0;
    long long triangles = 0;
    long long boundaryEdges = 0;   // edges with one triangle
    long long nonManifoldEdges = 0; // edges with three or more triangles
    long long nonManifoldVertices = 0; // vertices whose triangles do not form one fan
    long long misorientedEdges = 0; // edges whose two triangles run the same way along them
    int components = 0;            // connected by shared edges
    long long euler = 0;           // V - E + F
    double signedVolume = 0.0;     // world units^3; > 0 when closed and normals point outward
    bool closed() const { return boundaryEdges == 0; }
    bool manifold() const { return nonManifoldEdges == 0 && nonManifoldVertices == 0; }
    bool oriented() const { return misorientedEdges == 0; }
    bool outward() const { return signedVolume > 0.0; }
};

Topology checkTopology(const TriangleMesh& mesh);

/// Distance statistics, world units.
struct DistanceStats {
    double max = 0.0;
    double mean = 0.0;
    double rms = 0.0;
    long long samples = 0;
};

/// |signed field| of a level set at every vertex: the level set's own distance to its surface.
/// @throw Error if the volume is not a level set (a fog value is no distance).
DistanceStats levelSetDistanceAtVertices(const Volume& volume, const TriangleMesh& mesh);

} // namespace pipetile
