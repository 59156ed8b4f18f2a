// OutputSet: a run's outputs written all or nothing, locked against a second writer, and the
// leftovers of a killed run removed. Real files in a real folder; the CLI tests add real
// processes, signals and full disks.
#include <pipetile/error.h>
#include <pipetile/output_set.h>

#include "test_util.h"

#include <fstream>
#include <ostream>

using namespace pipetile;
using pipetile::test::TempDir;

namespace {

void put(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

std::string errorOf(const std::function<void()>& f)
{
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(OutputSet, CommitReplacesEveryTargetAndLeavesNothingElse)
{
    TempDir dir;
    put(dir.path("a.txt"), "old a");
    {
        OutputSet set({dir.path("a.txt"), dir.path("b.txt")});
        set.write(dir.path("a.txt"), [](std::ostream& out) { out << "new a"; });
        set.write(dir.path("b.txt"), [](std::ostream& out) { out << "new b"; });
        // Before the commit: the targets are as they were; temporaries and locks are hidden siblings.
        EXPECT_EQ(test::folderBytes(dir.path("")).at("a.txt"), "old a");
        EXPECT_EQ(test::folderBytes(dir.path("")).count("b.txt"), 0u);
        EXPECT_EQ(test::folderBytes(dir.path("")).at(".b.txt.pipetile-tmp"), "new b");
        EXPECT_NE(test::folderBytes(dir.path("")).at(".a.txt.pipetile-lock").find("pid "), std::string::npos);
        set.commit();
    }
    EXPECT_EQ(test::folderBytes(dir.path("")), (std::map<std::string, std::string>{{"a.txt", "new a"}, {"b.txt", "new b"}}));
}

TEST(OutputSet, UncommittedSetLeavesTheFolderAsItWas)
{
    // A run that fails after writing some outputs: the earlier files stay, nothing else appears.
    TempDir dir;
    put(dir.path("a.txt"), "old a");
    const auto before = test::folderBytes(dir.path(""));
    {
        OutputSet set({dir.path("a.txt"), dir.path("b.txt")});
        set.write(dir.path("a.txt"), [](std::ostream& out) { out << "new a"; });
    }
    EXPECT_TRUE(test::sameFiles(test::folderBytes(dir.path("")), before));
}

TEST(OutputSet, AWriterThatThrowsLeavesNoTemporaryAndNamesTheTarget)
{
    TempDir dir;
    OutputSet set({dir.path("a.txt")});
    const std::string message = errorOf([&] {
        set.write(dir.path("a.txt"), [](std::ostream& out) {
            out << "half";
            throw std::runtime_error("the writer gave up");
        });
    });
    EXPECT_NE(message.find("a.txt': cannot write it (the writer gave up)"), std::string::npos) << message;
    EXPECT_EQ(test::folderBytes(dir.path("")).count(".a.txt.pipetile-tmp"), 0u);
}

TEST(OutputSet, ASecondSetOnATargetFailsAndNamesTheFirst)
{
    // flock locks belong to open files, so two sets of one process exclude each other as two
    // processes do (the CLI tests run two processes). The second set takes nothing.
    TempDir dir;
    put(dir.path("b.txt"), "old b");
    OutputSet first({dir.path("a.txt"), dir.path("b.txt")}, "the first run");
    const std::string message = errorOf([&] { OutputSet second({dir.path("c.txt"), dir.path("b.txt")}); });
    EXPECT_NE(message.find("b.txt' is being written by another pipetile run (pid " + std::to_string(::getpid()) +
                           ": the first run)"),
              std::string::npos)
        << message;
    // The failed set released c.txt's lock: a third set can take it.
    EXPECT_NO_THROW(OutputSet third({dir.path("c.txt")}));
}

TEST(OutputSet, AFailedRenameMidSequenceRestoresTheTargetsBefore)
{
    // Targets: a (new), b (had content), c (a folder: cannot be replaced), d (had content).
    // The commit replaces a and b, fails at c, and puts a and b back: a gone, b's old content.
    TempDir dir;
    put(dir.path("b.txt"), "old b");
    std::filesystem::create_directory(dir.path("c.txt"));
    put(dir.path("d.txt"), "old d");
    const auto before = test::folderBytes(dir.path(""));
    OutputSet set({dir.path("a.txt"), dir.path("b.txt"), dir.path("c.txt"), dir.path("d.txt")});
    for (const char* name : {"a.txt", "b.txt", "c.txt", "d.txt"})
        set.write(dir.path(name), [&](std::ostream& out) { out << "new " << name; });
    const std::string message = errorOf([&] { set.commit(); });
    EXPECT_NE(message.find("c.txt': cannot replace it, it is a folder"), std::string::npos) << message;
    EXPECT_NE(message.find("nothing of this run was kept, the earlier files are as they were"), std::string::npos) << message;
    auto after = test::folderBytes(dir.path(""));
    after.erase(".a.txt.pipetile-lock"), after.erase(".b.txt.pipetile-lock"), after.erase(".c.txt.pipetile-lock"),
        after.erase(".d.txt.pipetile-lock"); // held until the set is gone
    EXPECT_EQ(after, before);
}

TEST(OutputSet, StaleTemporariesOfItsOwnTargetsAreRemovedAndNoOthers)
{
    // A killed run left a temporary and a kept-aside file for a.txt, and a temporary for x.txt,
    // which this set does not write: only a.txt's are its to remove.
    TempDir dir;
    put(dir.path(".a.txt.pipetile-tmp"), "killed run");
    put(dir.path(".a.txt.pipetile-old"), "killed commit");
    put(dir.path(".x.txt.pipetile-tmp"), "another output's");
    put(dir.path("a.txt.pipetile-tmp"), "not hidden: not pipetile's");
    {
        OutputSet set({dir.path("a.txt")});
        EXPECT_EQ(set.staleRemoved(), (std::vector<std::string>{dir.path(".a.txt.pipetile-tmp"), dir.path(".a.txt.pipetile-old")}));
    }
    EXPECT_EQ(dir.files(), (std::vector<std::string>{".x.txt.pipetile-tmp", "a.txt.pipetile-tmp"}));
}

TEST(OutputSet, AbandonedSetsRemoveTheirFilesAndRefuseToGoOn)
{
    // What the CLI's signal thread does: temporaries and lock files go at once, the targets stay.
    TempDir dir;
    put(dir.path("a.txt"), "old a");
    OutputSet set({dir.path("a.txt"), dir.path("b.txt")});
    set.write(dir.path("a.txt"), [](std::ostream& out) { out << "new a"; });
    abandonOutputs();
    EXPECT_EQ(test::folderBytes(dir.path("")), (std::map<std::string, std::string>{{"a.txt", "old a"}}));
    EXPECT_THROW(set.write(dir.path("b.txt"), [](std::ostream& out) { out << "new b"; }), Error);
    EXPECT_THROW(set.commit(), Error);
    EXPECT_EQ(dir.files(), (std::vector<std::string>{"a.txt"}));
}

TEST(OutputSet, AMissingFolderIsNamedBeforeAnythingIsWritten)
{
    TempDir dir;
    const std::string message = errorOf([&] { OutputSet set({dir.path("a.txt"), dir.path("no/such/b.txt")}); });
    EXPECT_NE(message.find("the folder '" + dir.path("no/such") + "' does not exist"), std::string::npos) << message;
    EXPECT_TRUE(dir.files().empty());
}
