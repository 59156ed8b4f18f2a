// pipetile — writes the seed corpus of fuzz_vdb: tiny .vdb files (one or two leaf nodes each) that
// readVolume accepts and Reconstruction meshes, in each storage variant the reader has to handle.
//   make_vdb_seeds DIR
// .ci/fuzz.sh runs it before fuzzing, so the seeds always match the installed OpenVDB. Even one
// leaf makes a file of about 10 KB: the masks of the two internal nodes above it (4 KB each for
// the 32^3 node) are written whole.

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

namespace {

using openvdb::Coord;
using openvdb::FloatGrid;

// A narrow-band level set of `distance` over the voxels of [lo, hi], background `band`.
template <class Distance>
FloatGrid::Ptr levelSet(const Coord& lo, const Coord& hi, float band, const Distance& distance)
{
    FloatGrid::Ptr grid = FloatGrid::create(band);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    auto acc = grid->getAccessor();
    for (int x = lo.x(); x <= hi.x(); ++x)
        for (int y = lo.y(); y <= hi.y(); ++y)
            for (int z = lo.z(); z <= hi.z(); ++z) {
                const float d = static_cast<float>(distance(x, y, z));
                if (std::abs(d) < band)
                    acc.setValueOn(Coord(x, y, z), d);
                else
                    acc.setValueOff(Coord(x, y, z), d < 0 ? -band : band);
            }
    return grid;
}

void write(const std::filesystem::path& dir, const std::string& name, openvdb::GridPtrVec grids,
           std::uint32_t compression)
{
    openvdb::io::File file((dir / name).string());
    file.setCompression(compression);
    file.write(grids);
    file.close();
    std::printf("%s: %ju bytes\n", name.c_str(), static_cast<std::uintmax_t>(std::filesystem::file_size(dir / name)));
}

} // namespace

int main(int argc, char** argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_vdb_seeds DIR\n");
        return 2;
    }
    openvdb::initialize();
    const std::filesystem::path dir = argv[1];
    std::filesystem::create_directories(dir);

    // A ball of radius 2.5 in one leaf node.
    auto ball = [](int x, int y, int z) {
        return std::sqrt((x - 3.5) * (x - 3.5) + (y - 3.5) * (y - 3.5) + (z - 3.5) * (z - 3.5)) - 2.5;
    };
    FloatGrid::Ptr sphere = levelSet(Coord(0), Coord(7), 2.0f, ball);
    sphere->setName("surface");
    // Active-mask compression only: no internal-node values, leaf values as plain floats.
    write(dir, "sphere_mask.vdb", {sphere}, openvdb::io::COMPRESS_ACTIVE_MASK);
    write(dir, "sphere_mask_zip.vdb", {sphere}, openvdb::io::COMPRESS_ACTIVE_MASK | openvdb::io::COMPRESS_ZIP);
    write(dir, "sphere_mask_blosc.vdb", {sphere}, openvdb::io::COMPRESS_ACTIVE_MASK | openvdb::io::COMPRESS_BLOSC);

    // A capped tube along z over two leaf nodes, stored as half floats.
    auto tube = [](int x, int y, int z) {
        const double radial = std::sqrt((x - 3.5) * (x - 3.5) + (y - 3.5) * (y - 3.5)) - 2.5;
        return std::max(radial, std::max(1.5 - z, z - 13.5));
    };
    FloatGrid::Ptr pipe = levelSet(Coord(0), Coord(7, 7, 15), 2.0f, tube);
    pipe->setName("pipe");
    pipe->setSaveFloatAsHalf(true);
    write(dir, "tube_half.vdb", {pipe}, openvdb::io::COMPRESS_ACTIVE_MASK);

    // A fog volume: an active constant tile (voxelized by readVolume) next to a leaf with a ramp,
    // plus a vector grid the reader must skip.
    FloatGrid::Ptr fog = FloatGrid::create(0.0f);
    fog->setName("density");
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    fog->tree().addTile(1, Coord(8, 0, 0), 1.0f, true);
    auto acc = fog->getAccessor();
    for (int x = 0; x < 8; ++x)
        for (int y = 0; y < 8; ++y)
            for (int z = 0; z < 8; ++z) acc.setValueOn(Coord(x, y, z), x / 8.0f);
    openvdb::Vec3SGrid::Ptr velocity = openvdb::Vec3SGrid::create();
    velocity->setName("velocity");
    velocity->tree().setValueOn(Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
    write(dir, "fog_tile_vec3.vdb", {velocity, fog}, openvdb::io::COMPRESS_ACTIVE_MASK);
    return 0;
}
