// OutputSet: a run's outputs written all or nothing, locked against a second writer, and the
// leftovers of a killed run removed. Real files in a real folder; the CLI tests add real
// processes, signals and full disks.
#include <pipetile/error.h>
#include <pipetile/output_set.h>

#include "test_util.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <thread>

using namespace pipetile;
using pipetile::test::TempDir;

namespace {

void put(const std::string& path, const std::string& text)
{
    std::ofstream(path, std::ios::binary) << text;
}

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
    EXPECT_EQ(test::folderBytes(dir.path("")),
              (std::map<std::string, std::string>{{"a.txt", "new a"}, {"b.txt", "new b"}}));
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
    EXPECT_NE(message.find("nothing of this run was kept, the earlier files are as they were"), std::string::npos)
        << message;
    auto after = test::folderBytes(dir.path(""));
    after.erase(".a.txt.pipetile-lock"), after.erase(".b.txt.pipetile-lock"), after.erase(".c.txt.pipetile-lock"),
        after.erase(".d.txt.pipetile-lock"); // held until the set is gone
    EXPECT_EQ(after, before);
}

TEST(OutputSet, StaleTemporariesOfItsOwnTargetsAreRemovedAndNoOthers)
{
    // A killed run left a temporary and a kept-aside file for a.txt (which exists), and a
    // temporary for x.txt, which this set does not write: only a.txt's are its to remove.
    TempDir dir;
    put(dir.path("a.txt"), "old a");
    put(dir.path(".a.txt.pipetile-tmp"), "killed run");
    put(dir.path(".a.txt.pipetile-old"), "killed commit");
    put(dir.path(".x.txt.pipetile-tmp"), "another output's");
    put(dir.path("a.txt.pipetile-tmp"), "not hidden: not pipetile's");
    {
        OutputSet set({dir.path("a.txt")});
        EXPECT_EQ(set.staleRemoved(),
                  (std::vector<std::string>{dir.path(".a.txt.pipetile-tmp"), dir.path(".a.txt.pipetile-old")}));
    }
    EXPECT_EQ(dir.files(), (std::vector<std::string>{".x.txt.pipetile-tmp", "a.txt", "a.txt.pipetile-tmp"}));
    EXPECT_EQ(test::folderBytes(dir.path("")).at("a.txt"), "old a");
}

TEST(OutputSet, AKeptAsideFileWithoutARecordComesBackWhereItsTargetIsGone)
{
    // A kept-aside file with no commit record (an older pipetile killed between moving a.txt
    // aside and renaming its temporary) is the only copy of a.txt: it is put back, not removed.
    TempDir dir;
    put(dir.path(".a.txt.pipetile-old"), "earlier a");
    put(dir.path(".a.txt.pipetile-tmp"), "killed run");
    {
        OutputSet set({dir.path("a.txt")});
        EXPECT_EQ(set.recovered(), (std::vector<std::string>{dir.path("a.txt")}));
    }
    EXPECT_EQ(test::folderBytes(dir.path("")), (std::map<std::string, std::string>{{"a.txt", "earlier a"}}));
}

TEST(OutputSet, ObsoleteFilesGoWithTheCommitAndNoOthers)
{
    // A run with two levels after one with four: m_L2 and m_L3 are obsolete and go when it
    // commits, not before (a reader sees the earlier set until then); other files stay.
    TempDir dir;
    for (const char* name : {"m_L0.ply", "m_L1.ply", "m_L2.ply", "m_L3.ply", "m_L2.obj"}) put(dir.path(name), "old");
    OutputSet set({dir.path("m_L0.ply"), dir.path("m_L1.ply")}, "", {dir.path("m_L2.ply"), dir.path("m_L3.ply")});
    for (const char* name : {"m_L0.ply", "m_L1.ply"})
        set.write(dir.path(name), [](std::ostream& out) { out << "new"; });
    EXPECT_THROW(set.write(dir.path("m_L2.ply"), [](std::ostream& out) { out << "new"; }), UsageError);
    EXPECT_EQ(test::folderBytes(dir.path("")).at("m_L3.ply"), "old");
    set.commit();
    auto after = test::folderBytes(dir.path(""));
    for (const char* lock :
         {".m_L0.ply.pipetile-lock", ".m_L1.ply.pipetile-lock", ".m_L2.ply.pipetile-lock", ".m_L3.ply.pipetile-lock"})
        EXPECT_EQ(after.erase(lock), 1u) << lock; // held until the set is gone
    EXPECT_EQ(after,
              (std::map<std::string, std::string>{{"m_L0.ply", "new"}, {"m_L1.ply", "new"}, {"m_L2.obj", "old"}}));
}

TEST(OutputSet, ObsoleteFilesComeBackWhenTheCommitFails)
{
    // The obsolete files go first; then b.txt, a folder, cannot be replaced: they come back.
    TempDir dir;
    put(dir.path("m_L2.ply"), "old 2");
    put(dir.path("m_L3.ply"), "old 3");
    std::filesystem::create_directory(dir.path("b.txt"));
    const auto before = test::folderBytes(dir.path(""));
    {
        OutputSet set({dir.path("a.txt"), dir.path("b.txt")}, "", {dir.path("m_L2.ply"), dir.path("m_L3.ply")});
        for (const char* name : {"a.txt", "b.txt"}) set.write(dir.path(name), [](std::ostream& out) { out << "new"; });
        const std::string message = errorOf([&] { set.commit(); });
        EXPECT_NE(message.find("b.txt': cannot replace it, it is a folder"), std::string::npos) << message;
        EXPECT_NE(message.find("the earlier files are as they were"), std::string::npos) << message;
    }
    EXPECT_EQ(test::folderBytes(dir.path("")), before);
    EXPECT_TRUE(std::filesystem::is_directory(dir.path("b.txt")));
}

namespace {

// The folder's files without its lock files (a killed run leaves those; they hold no content).
std::map<std::string, std::string> withoutLocks(std::map<std::string, std::string> files)
{
    for (auto it = files.begin(); it != files.end();)
        it = it->first.find(".pipetile-lock") != std::string::npos ? files.erase(it) : std::next(it);
    return files;
}

// A child process that opens a set over `targets` (and `obsolete`), writes "new" into each, tells
// the parent through a pipe that it is about to commit, commits and exits. Returns its pid and
// the pipe's reading end.
std::pair<pid_t, int> commitInChild(const std::vector<std::string>& targets, const std::vector<std::string>& obsolete)
{
    int pipeFds[2];
    if (::pipe(pipeFds) != 0) return {-1, -1};
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::close(pipeFds[0]);
        try {
            OutputSet set(targets, "the child", obsolete);
            for (const std::string& t : targets) set.write(t, [](std::ostream& out) { out << "new"; });
            if (::write(pipeFds[1], "c", 1) != 1) ::_exit(3);
            set.commit();
        } catch (...) {
            ::_exit(2);
        }
        ::_exit(0);
    }
    ::close(pipeFds[1]);
    return {pid, pipeFds[0]};
}

} // namespace

TEST(OutputSet, ACommitKilledHalfwayIsFinishedByTheNextSet)
{
    // SIGKILL at points across a real commit of 40 targets and 8 obsolete files (a child process,
    // killed by its parent after delays spread over how long an uninterrupted commit takes). Then
    // a set over the same files is opened and dropped, as a next run that fails does. Whatever
    // the point, the folder then holds the earlier set or the child's whole set, and nothing else:
    // never a mix, never a temporary.
    TempDir dir;
    std::vector<std::string> targets, obsolete;
    std::map<std::string, std::string> earlier, complete;
    for (int k = 0; k < 40; ++k) {
        const std::string name = "m_L" + std::to_string(k) + ".ply";
        targets.push_back(dir.path(name));
        earlier[name] = "old";
        complete[name] = "new";
    }
    for (int k = 40; k < 48; ++k) {
        const std::string name = "m_L" + std::to_string(k) + ".ply";
        obsolete.push_back(dir.path(name));
        earlier[name] = "old";
    }
    auto reset = [&] {
        std::filesystem::remove_all(dir.path(""));
        std::filesystem::create_directory(dir.path(""));
        for (const auto& [name, text] : earlier) put(dir.path(name), text);
    };
    // How long an uninterrupted commit takes, from the child's word to its exit.
    reset();
    auto [calibration, calibrationPipe] = commitInChild(targets, obsolete);
    ASSERT_GT(calibration, 0);
    char byte = 0;
    ASSERT_EQ(::read(calibrationPipe, &byte, 1), 1);
    const auto start = std::chrono::steady_clock::now();
    int status = 0;
    ::waitpid(calibration, &status, 0);
    ::close(calibrationPipe);
    const double commitSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    ASSERT_EQ(withoutLocks(test::folderBytes(dir.path(""))), complete);

    int halfway = 0;
    constexpr int kPoints = 16;
    for (int point = 0; point <= kPoints; ++point) {
        SCOPED_TRACE("killed " + std::to_string(point) + "/" + std::to_string(kPoints) + " of " +
                     std::to_string(commitSeconds) + " s into the commit");
        reset();
        auto [child, fromChild] = commitInChild(targets, obsolete);
        ASSERT_GT(child, 0);
        ASSERT_EQ(::read(fromChild, &byte, 1), 1);
        std::this_thread::sleep_for(std::chrono::duration<double>(commitSeconds * point / kPoints));
        ::kill(child, SIGKILL);
        ::waitpid(child, &status, 0);
        ::close(fromChild);
        const auto left = withoutLocks(test::folderBytes(dir.path("")));
        if (left != earlier && left != complete) ++halfway;
        {
            // As the CLI's next run, which names the obsolete levels it finds.
            std::vector<std::string> found;
            for (const std::string& path : obsolete)
                if (std::filesystem::exists(path)) found.push_back(path);
            OutputSet next(targets, "the next run", found);
        }
        const auto after = test::folderBytes(dir.path(""));
        EXPECT_TRUE(after == earlier || after == complete) << test::sameFiles(after, complete).message();
    }
    // Some points must land inside the commit, or this test did not test it.
    EXPECT_GE(halfway, 1);
    RecordProperty("halfway_of_17", halfway);
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
