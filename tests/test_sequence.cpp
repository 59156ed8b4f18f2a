// Frame sequences: patterns and ranges (tools/sequence.h), and `pipetile mesh` on a generated
// 24-frame sequence, end to end through the real executable.
#include "sequence.h"
#include "test_util.h"

#include <pipetile/error.h>

#include <nlohmann/json.hpp>
#include <openvdb/io/File.h>
#include <openvdb/tools/LevelSetSphere.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

using namespace pipetile;
using pipetile::test::runCli;
using pipetile::test::TempDir;
using tools::FramePattern;

namespace {

constexpr int kFirst = 1001, kFrames = 24;

// Frame f of the sequence: a level set sphere whose radius grows by 0.25 voxel a frame (4 to
// 9.75), so every frame's mesh differs from the others'.
void writeSphereFrame(const std::string& path, int frame)
{
    openvdb::initialize();
    const float radius = 4.0f + 0.25f * static_cast<float>(frame - kFirst);
    openvdb::FloatGrid::Ptr grid =
        openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(radius, openvdb::Vec3f(0.0f), 1.0f, 3.0f);
    grid->setName("sphere");
    openvdb::io::File(path).write({grid});
}

// The 24 frames seq.1001.vdb ... seq.1024.vdb in `dir`, and an out/ folder for the meshes.
void writeSequence(const TempDir& dir)
{
    for (int f = kFirst; f < kFirst + kFrames; ++f) writeSphereFrame(dir.path("seq." + std::to_string(f) + ".vdb"), f);
    std::filesystem::create_directory(dir.path("out"));
}

std::string fileBytes(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

nlohmann::json readJson(const std::string& path)
{
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

std::string levelFile(const TempDir& dir, const std::string& folder, int frame, int level)
{
    return dir.path(folder + "/seq." + std::to_string(frame) + "_L" + std::to_string(level) + ".ply");
}

ino_t inode(const std::string& path)
{
    struct stat s {};
    return ::stat(path.c_str(), &s) == 0 ? s.st_ino : 0;
}

} // namespace

TEST(Sequence, PatternsOfHoudiniPrintfAndHashesNameTheSameFiles)
{
    for (const std::string text : {"sim/smoke.####.vdb", "sim/smoke.$F4.vdb", "sim/smoke.%04d.vdb"}) {
        SCOPED_TRACE(text);
        const std::optional<FramePattern> pattern = FramePattern::parse(text);
        ASSERT_TRUE(pattern);
        EXPECT_EQ(pattern->path(7), "sim/smoke.0007.vdb");
        EXPECT_EQ(pattern->path(1001), "sim/smoke.1001.vdb");
        EXPECT_EQ(pattern->path(123456), "sim/smoke.123456.vdb"); // wider than the padding: in full
    }
    // Unpadded forms: $F and %d.
    EXPECT_EQ(FramePattern::parse("a.$F.vdb")->path(7), "a.7.vdb");
    EXPECT_EQ(FramePattern::parse("a.%d.vdb")->path(7), "a.7.vdb");
    EXPECT_EQ(FramePattern::parse("a.##.vdb")->path(7), "a.07.vdb");
    // No token: a plain file name, and a '%' that is no frame number.
    EXPECT_FALSE(FramePattern::parse("sim/smoke.1001.vdb"));
    EXPECT_FALSE(FramePattern::parse("sim/100%.vdb"));
}

TEST(Sequence, FrameRangesIncludeBothEndsAndStep)
{
    EXPECT_EQ(tools::parseFrameRange("1001-1004"), (std::vector<int>{1001, 1002, 1003, 1004}));
    EXPECT_EQ(tools::parseFrameRange("1-10:4"), (std::vector<int>{1, 5, 9}));
    EXPECT_EQ(tools::parseFrameRange("12"), (std::vector<int>{12}));
    for (const char* bad : {"5-3", "1-10:0", "a-b", "", "1-", "-4", "1-4:x"}) {
        SCOPED_TRACE(bad);
        EXPECT_THROW(tools::parseFrameRange(bad), UsageError);
    }
}

TEST(Sequence, ExistingFramesAreTheFilesSpelledAsThePatternSpellsThem)
{
    TempDir dir;
    for (const char* name :
         {"seq.0003.vdb", "seq.0010.vdb", "seq.12345.vdb", "seq.12.vdb", "seq.0004.vdb.bak", "other.0005.vdb"})
        test::writeTextFile(dir.path(name), "");
    // seq.12.vdb is not four digits, the .bak and other.* are other names.
    EXPECT_EQ(FramePattern::parse(dir.path("seq.####.vdb"))->existingFrames(), (std::vector<int>{3, 10, 12345}));
    EXPECT_THROW(FramePattern::parse(dir.path("f####/seq.vdb"))->existingFrames(), UsageError);
}

TEST(CliSequence, EveryFrameEqualsItsSingleFileRunByteForByte)
{
    TempDir dir;
    writeSequence(dir);
    std::filesystem::create_directory(dir.path("single"));
    // No --frames: the 24 files that match. $F4 for the input, %04d for the outputs.
    const test::CliResult r =
        runCli("mesh '" + dir.path("seq.$F4.vdb") + "' -o '" + dir.path("out/seq.%04d.ply") + "' --report '" +
               dir.path("out/seq.####.json") + "' --summary '" + dir.path("summary.json") + "'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    long long triangles = 0;
    for (int f = kFirst; f < kFirst + kFrames; ++f) {
        SCOPED_TRACE("frame " + std::to_string(f));
        const std::string frame = std::to_string(f);
        ASSERT_EQ(runCli("mesh '" + dir.path("seq." + frame + ".vdb") + "' -o '" +
                         dir.path("single/seq." + frame + ".ply") + "'")
                      .exitCode,
                  0);
        for (int level = 0; level < 4; ++level) {
            const std::string batch = fileBytes(levelFile(dir, "out", f, level));
            EXPECT_FALSE(batch.empty());
            EXPECT_TRUE(batch == fileBytes(levelFile(dir, "single", f, level))) << "level " << level;
        }
        const nlohmann::json report = readJson(dir.path("out/seq." + frame + ".json"));
        EXPECT_EQ(report["input"].get<std::string>(), dir.path("seq." + frame + ".vdb"));
        for (const auto& level : report["levels"]) triangles += level["triangles"].get<long long>();
    }
    // The aggregate: every frame meshed, and its totals are the frames' reports summed.
    const nlohmann::json summary = readJson(dir.path("summary.json"));
    EXPECT_EQ(summary["frames"].get<int>(), kFrames);
    EXPECT_EQ(summary["meshed"].get<int>(), kFrames);
    EXPECT_EQ(summary["failed"].get<int>(), 0);
    EXPECT_EQ(summary["totals"]["triangles"].get<long long>(), triangles);
    EXPECT_EQ(summary["per_frame"].size(), static_cast<std::size_t>(kFrames));
}

TEST(CliSequence, ADamagedAndAMissingFrameAreNamedAndTheOthersWritten)
{
    TempDir dir;
    writeSequence(dir);
    const std::string damaged = dir.path("seq.1005.vdb");
    std::filesystem::resize_file(damaged, std::filesystem::file_size(damaged) / 2);
    std::filesystem::remove(dir.path("seq.1010.vdb"));
    const test::CliResult r = runCli("mesh '" + dir.path("seq.####.vdb") + "' --frames 1001-1024 -o '" +
                                     dir.path("out/seq.####.ply") + "' --summary '" + dir.path("summary.json") + "'");
    EXPECT_EQ(r.exitCode, 1) << r.err;
    for (const char* frame : {"1005", "1010"}) {
        const std::string line = "pipetile: error: frame " + std::string(frame) + ": ";
        const std::size_t at = r.err.find(line);
        ASSERT_NE(at, std::string::npos) << r.err;
        // One line, naming the file.
        const std::string message = r.err.substr(at, r.err.find('\n', at) - at);
        EXPECT_NE(message.find(dir.path("seq." + std::string(frame) + ".vdb")), std::string::npos) << message;
    }
    // 22 frames of 4 levels each, nothing of the two failed frames, no temporaries or locks.
    std::vector<std::string> expected;
    for (int f = kFirst; f < kFirst + kFrames; ++f)
        if (f != 1005 && f != 1010)
            for (int level = 0; level < 4; ++level)
                expected.push_back("seq." + std::to_string(f) + "_L" + std::to_string(level) + ".ply");
    std::sort(expected.begin(), expected.end());
    std::vector<std::string> written;
    for (const auto& entry : std::filesystem::directory_iterator(dir.path("out")))
        written.push_back(entry.path().filename().string());
    std::sort(written.begin(), written.end());
    EXPECT_EQ(written, expected);
    const nlohmann::json summary = readJson(dir.path("summary.json"));
    EXPECT_EQ(summary["meshed"].get<int>(), kFrames - 2);
    ASSERT_EQ(summary["failed"].get<int>(), 2);
    EXPECT_EQ(summary["failures"][0]["frame"].get<int>(), 1005);
    EXPECT_EQ(summary["failures"][1]["frame"].get<int>(), 1010);
    EXPECT_EQ(summary["failures"][0]["error"].get<std::string>().rfind("frame 1005: ", 0), 0u);
}

TEST(CliSequence, SkipExistingRerunsNothingAndResumesAStoppedRun)
{
    TempDir dir;
    writeSequence(dir);
    const std::string args = "mesh '" + dir.path("seq.####.vdb") + "' -o '" + dir.path("out/seq.####.ply") +
                             "' --report '" + dir.path("out/seq.####.json") + "' --skip-existing --summary '" +
                             dir.path("summary.json") + "'";
    ASSERT_EQ(runCli(args).exitCode, 0);
    // Every output is committed by a rename, so a file written again is a new inode.
    std::map<std::string, ino_t> inodes;
    for (const auto& entry : std::filesystem::directory_iterator(dir.path("out")))
        inodes[entry.path()] = inode(entry.path());
    EXPECT_EQ(inodes.size(), static_cast<std::size_t>(kFrames * 5)); // 4 levels and a report per frame

    const test::CliResult again = runCli(args);
    ASSERT_EQ(again.exitCode, 0) << again.err;
    EXPECT_EQ(readJson(dir.path("summary.json"))["skipped"].get<int>(), kFrames);
    EXPECT_EQ(readJson(dir.path("summary.json"))["meshed"].get<int>(), 0);
    for (const auto& [path, number] : inodes) EXPECT_EQ(inode(path), number) << path;

    // A run stopped before frame 1017's commit left none of its files: only that frame is meshed.
    for (int level = 0; level < 4; ++level) std::filesystem::remove(levelFile(dir, "out", 1017, level));
    std::filesystem::remove(dir.path("out/seq.1017.json"));
    ASSERT_EQ(runCli(args).exitCode, 0);
    const nlohmann::json summary = readJson(dir.path("summary.json"));
    EXPECT_EQ(summary["meshed"].get<int>(), 1);
    EXPECT_EQ(summary["skipped"].get<int>(), kFrames - 1);
    for (const auto& [path, number] : inodes) {
        if (std::filesystem::path(path).filename().string().rfind("seq.1017", 0) != 0) {
            EXPECT_EQ(inode(path), number) << path;
        }
    }
    EXPECT_TRUE(std::filesystem::exists(levelFile(dir, "out", 1017, 3)));
}

TEST(CliSequence, OutputsWithoutAFrameNumberAreUsageErrors)
{
    TempDir dir;
    writeSequence(dir);
    const std::string input = "'" + dir.path("seq.####.vdb") + "'";
    for (const std::string& args :
         {"mesh " + input + " -o '" + dir.path("out/one.ply") + "'",
          "mesh " + input + " -o '" + dir.path("out/s.####.ply") + "' --report '" + dir.path("r.json") + "'",
          "mesh " + input + " --frames 9-3", "mesh '" + dir.path("seq.1001.vdb") + "' --frames 1-3"}) {
        const test::CliResult r = runCli(args);
        EXPECT_EQ(r.exitCode, 2) << args << ": " << r.err;
        EXPECT_NE(r.err.find("usage error"), std::string::npos) << r.err;
    }
    EXPECT_TRUE(std::filesystem::is_empty(dir.path("out")));
}
