#include <pipetile/error.h>
#include <pipetile/volume_grid.h>

#include "test_util.h"

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <fstream>
#include <limits>

using namespace pipetile;
using pipetile::test::realData;
using pipetile::test::TempDir;

namespace {

openvdb::FloatGrid::Ptr smallLevelSet(float background = 3.0f)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(background);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName("ls");
    auto acc = grid->getAccessor();
    for (int i = -4; i <= 4; ++i)
        for (int j = -4; j <= 4; ++j)
            for (int k = -4; k <= 4; ++k)
                acc.setValue(openvdb::Coord(i, j, k), static_cast<float>(std::sqrt(i * i + j * j + k * k) - 2.5));
    return grid;
}

std::string messageOf(const std::function<void()>& f)
{
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

} // namespace

TEST(Volume, ReadsHalfFloatLevelSetWrittenByHoudini)
{
    // gaffer_sphere_levelset.vdb stores half floats; OpenVDB widens them to float on read.
    const Volume v = readVolume(realData("gaffer_sphere_levelset.vdb"));
    EXPECT_EQ(v.gridName(), "ls_sphere");
    EXPECT_EQ(v.volumeClass(), VolumeClass::LevelSet);
    EXPECT_EQ(v.iso(), 0.0);
    EXPECT_NEAR(v.smallestVoxel(), 0.05, 1e-9); // the data README's voxel size
}

TEST(Volume, BloscFogDefaultIsoIsHalfwayFromBackgroundToMax)
{
    // Background 0 and densest value 1 (vdb_print): the documented default isovalue is 0.5.
    const Volume v = readVolume(realData("gaffer_sphere_density_fog.vdb"));
    EXPECT_EQ(v.volumeClass(), VolumeClass::Fog);
    EXPECT_NEAR(v.iso(), 0.5, 1e-6);
}

TEST(Volume, ConeFogDefaultIsoIsMinusFiveHundred)
{
    // Background -1000 (air), tissue 0: halfway is -500, the isovalue the data README gives.
    const Volume v = readVolume(realData("cip_cone_vessel_density.vdb"));
    EXPECT_EQ(v.volumeClass(), VolumeClass::Fog);
    EXPECT_DOUBLE_EQ(v.iso(), -500.0);
    EXPECT_LT(v.signedField(v.indexToWorld({25, 25, 180})), 0.0); // on the cone's axis: inside
}

TEST(Volume, KeepsAnisotropicVoxelsOfTheAorta)
{
    const Volume v = readVolume(realData("vmtk_aorta_ls.vdb"));
    EXPECT_NEAR(v.voxelSize().x, 0.879, 0.001);
    EXPECT_NEAR(v.voxelSize().y, 0.879, 0.001);
    EXPECT_NEAR(v.voxelSize().z, 1.5, 0.001);
    EXPECT_NEAR(v.smallestVoxel(), v.voxelSize().x, 1e-12);
    EXPECT_FALSE(v.mirrored());
}

TEST(Volume, MissingFileIsNamed)
{
    const std::string msg = messageOf([] { readVolume("/nonexistent/vessel.vdb"); });
    EXPECT_NE(msg.find("/nonexistent/vessel.vdb"), std::string::npos) << msg;
    EXPECT_NE(msg.find("no such file"), std::string::npos) << msg;
}

TEST(Volume, TextFileNamedVdbIsRefused)
{
    TempDir dir;
    std::ofstream(dir.path("notes.vdb")) << "these are notes, not voxels\n";
    const std::string msg = messageOf([&] { readVolume(dir.path("notes.vdb")); });
    EXPECT_NE(msg.find("not a readable VDB file"), std::string::npos) << msg;
}

TEST(Volume, TruncatedFileIsRefused)
{
    TempDir dir;
    std::ifstream in(realData("vmtk_aorta_ls.vdb"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir.path("cut.vdb"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    const std::string msg = messageOf([&] { readVolume(dir.path("cut.vdb")); });
    EXPECT_NE(msg.find("cut.vdb"), std::string::npos) << msg;
    EXPECT_NE(msg.find("levelset"), std::string::npos) << msg; // the grid that could not be read
}

TEST(Volume, UnknownGridNameListsTheGrids)
{
    const std::string msg = messageOf([] { readVolume(realData("vmtk_aorta_ls.vdb"), {"density", {}}); });
    EXPECT_NE(msg.find("no grid named 'density'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'levelset' (float)"), std::string::npos) << msg;
}

TEST(Volume, VectorGridIsRefusedWithItsType)
{
    TempDir dir;
    test::writeVectorGridVdb(dir.path("vel.vdb"));
    EXPECT_NE(messageOf([&] { readVolume(dir.path("vel.vdb")); }).find("no scalar float grid"), std::string::npos);
    EXPECT_NE(messageOf([&] { readVolume(dir.path("vel.vdb"), {"velocity", {}}); }).find("vec3s"), std::string::npos);
}

TEST(Volume, UnnamedFloatGridIsMeshed)
{
    // pyopenvdb's default name is '': such a grid is the file's first float grid like any other.
    TempDir dir;
    openvdb::FloatGrid::Ptr grid = smallLevelSet();
    grid->setName("");
    openvdb::io::File(dir.path("unnamed.vdb")).write({grid});
    const Volume volume = readVolume(dir.path("unnamed.vdb"));
    EXPECT_EQ(volume.gridName(), "");
    EXPECT_EQ(volume.volumeClass(), VolumeClass::LevelSet);
    EXPECT_NEAR(volume.signedField({2.5, 0.0, 0.0}), 0.0, 1e-6); // the sphere of radius 2.5
}

TEST(Volume, FirstFloatGridIsTheOneTheGridListShowsFirst)
{
    // Two float grids written 'b' then 'a', with a vector grid before them. io::File lists the grids
    // of a file with grid offsets (io::File writes them) by name, and those of a file without
    // (io::Stream) in file order: the grid mesh picks is the first float grid of that list,
    // however the file was read.
    TempDir dir;
    openvdb::FloatGrid::Ptr b = smallLevelSet(), a = smallLevelSet();
    b->setName("b");
    a->setName("a");
    auto velocity = openvdb::Vec3SGrid::create();
    velocity->setName("0velocity");
    velocity->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
    const openvdb::GridCPtrVec grids{velocity, b, a};
    openvdb::io::File(dir.path("offsets.vdb")).write(grids);
    {
        std::ofstream out(dir.path("stream.vdb"), std::ios::binary);
        openvdb::io::Stream(out).write(grids);
    }
    for (const auto& [file, first] : {std::pair{"offsets.vdb", "a"}, std::pair{"stream.vdb", "b"}}) {
        const std::vector<GridSummary> listed = listGrids(dir.path(file));
        const auto firstFloat =
            std::find_if(listed.begin(), listed.end(), [](const GridSummary& g) { return g.valueType == "float"; });
        ASSERT_NE(firstFloat, listed.end()) << file;
        EXPECT_EQ(firstFloat->name, first) << file;
        EXPECT_EQ(readVolume(dir.path(file)).gridName(), first) << file;
        EXPECT_EQ(readVolume(dir.path(file), {"b", {}}).gridName(), "b") << file; // by name, either way
    }
}

TEST(Volume, EmptyGridIsRefused)
{
    auto grid = openvdb::FloatGrid::create(3.0f);
    grid->setName("empty");
    EXPECT_NE(messageOf([&] { volumeFromGrid(grid, {}, "mem"); }).find("empty"), std::string::npos);
}

TEST(Volume, NonFiniteValuesAreRefused)
{
    auto grid = smallLevelSet();
    grid->tree().setValue(openvdb::Coord(1, 1, 1), std::numeric_limits<float>::quiet_NaN());
    grid->tree().setValue(openvdb::Coord(1, 2, 1), std::numeric_limits<float>::infinity());
    EXPECT_NE(messageOf([&] { volumeFromGrid(grid, {}, "mem"); }).find("2 NaN or infinite"), std::string::npos);
}

TEST(Volume, IsovalueOutsideTheRangeGivesTheRange)
{
    // smallLevelSet holds |p| - 2.5 on [-4, 4]^3: from -2.5 at the centre to sqrt(48) - 2.5 =
    // 4.4282 at the corners.
    const std::string msg = messageOf([&] { volumeFromGrid(smallLevelSet(), {"", 7.0}, "mem"); });
    EXPECT_NE(msg.find("crosses nothing"), std::string::npos) << msg;
    EXPECT_NE(msg.find("-2.5 to 4.4282"), std::string::npos) << msg;
}

TEST(Volume, BackgroundInsideTheSurfaceIsRefused)
{
    // A level set whose background is negative encloses all of space: no bounded object.
    auto grid = smallLevelSet(-3.0f);
    EXPECT_NE(messageOf([&] { volumeFromGrid(grid, {"", 0.0}, "mem"); }).find("unbounded"), std::string::npos);
}

namespace {

// The fog tube of test::writeTubeFogVdb, in memory, with `hot` voxels of 100 on its axis.
openvdb::FloatGrid::Ptr tubeFogWithHotVoxels(int hot)
{
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    auto acc = grid->getAccessor();
    for (int i = 0; i < 24; ++i)
        for (int j = 0; j < 24; ++j)
            for (int k = 0; k < 48; ++k)
                acc.setValue(openvdb::Coord(i, j, k),
                             static_cast<float>(std::clamp(6.5 - std::hypot(i - 11.5, j - 11.5), 0.0, 1.0)));
    for (int k = 0; k < hot; ++k) acc.setValue(openvdb::Coord(11, 11, k), 100.0f);
    return grid;
}

} // namespace

TEST(Volume, HotVoxelsTooFewToBeAnObjectDoNotSetTheDefaultFogIso)
{
    // A 0..1 tube (value above 0.5 within radius 6: 112 pixels a section, 5376 voxels in its 48
    // sections) with voxels of 100 on its axis. Halfway to 100 would put the surface around those
    // voxels alone; while fewer than 27 (a 3^3 block) of them would lie inside, the default is
    // halfway to 1, the next densest value, and they are counted as hot.
    for (const auto& [hot, iso, hotVoxels, inside] : std::vector<std::tuple<int, double, long long, long long>>{
             {0, 0.5, 0, 5376}, {1, 0.5, 1, 5376}, {26, 0.5, 26, 5376}, {27, 50.0, 0, 27}}) {
        SCOPED_TRACE(std::to_string(hot) + " hot voxels");
        const Volume v = volumeFromGrid(tubeFogWithHotVoxels(hot), {}, "tube");
        EXPECT_DOUBLE_EQ(v.iso(), iso);
        EXPECT_EQ(v.hotVoxels(), hotVoxels);
        EXPECT_EQ(v.insideVoxels(), inside); // the hot voxels lie on the axis, inside the tube
        EXPECT_EQ(v.maxValue(), hot > 0 ? 100.0 : 1.0);
    }
}

TEST(Volume, MessagesNameSettingsInWordsNotByFlag)
{
    // The library cannot know whether a command line, Python or a C++ program asked: it names the
    // setting to change in Error::settings(), and each front end adds its own name for it.
    try {
        VolumeOptions options;
        options.gridName = "density";
        readVolume(realData("vmtk_aorta_ls.vdb"), options);
        FAIL() << "the aorta has no grid named 'density'";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("pick one by name"), std::string::npos) << message;
        EXPECT_EQ(message.find("--"), std::string::npos) << message;
        EXPECT_EQ(e.settings(), std::vector<Setting>{Setting::Grid});
    }
    try {
        VolumeOptions options;
        options.iso = 100.0; // the aorta's values run from -3.5 to 3.5
        readVolume(realData("vmtk_aorta_ls.vdb"), options);
        FAIL() << "isovalue 100 crosses nothing";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << e.what();
        EXPECT_EQ(e.settings(), std::vector<Setting>{Setting::Iso});
    }
}

TEST(Volume, AGridNameFromTheFileIsShownCutShortAndEscaped)
{
    // A file may name its grids with anything: messages quote a name's first 100 bytes, with the
    // bytes below a space written as \xNN (an escape sequence would drive the user's terminal),
    // and list 20 grids of many. Here 25 grids, the first named ESC "[2J" and a megabyte.
    TempDir dir;
    openvdb::GridPtrVec grids;
    for (int i = 0; i < 25; ++i) {
        openvdb::FloatGrid::Ptr grid = smallLevelSet();
        grid->setName(i == 0 ? "\x1b[2J" + std::string(1 << 20, 'a') : "g" + std::to_string(i));
        grids.push_back(grid);
    }
    openvdb::io::File(dir.path("names.vdb")).write(grids);
    const std::string msg = messageOf([&] { readVolume(dir.path("names.vdb"), {"density", {}}); });
    EXPECT_LT(msg.size(), 1000u) << msg.substr(0, 400);
    EXPECT_NE(msg.find("'\\x1b[2J" + std::string(96, 'a') + "...' (float)"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\x1b'), std::string::npos) << msg;
    EXPECT_NE(msg.find(", and 5 more"), std::string::npos) << msg;
    EXPECT_EQ(printableName("levelset"), "levelset");
}
