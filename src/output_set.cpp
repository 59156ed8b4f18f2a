// pipetile — output_set: a run's output files as one transaction (temporaries, checked writes,
// renames, rollback), with a lock per output against concurrent runs.

#include <pipetile/error.h>
#include <pipetile/output_set.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <ostream>
#include <set>
#include <streambuf>

namespace pipetile {

namespace {

enum class State {
    Open,       // temporaries may be written
    Committing, // renaming: left as it is if the process ends now (the next run recovers it)
    Committed,  // every target holds this run's file
    Abandoned,  // a signal ended the run: temporaries and lock files are gone
};

struct Target {
    std::string path;      // as the caller named it
    std::string temporary; // .NAME.pipetile-tmp: this run's new content until commit
    std::string previous;  // .NAME.pipetile-old: the earlier content, during commit only
    std::string lock;      // .NAME.pipetile-lock: flock'ed by the run that writes NAME
    bool obsolete = false; // removed by the commit (a level of an earlier run with more levels)
    int lockFd = -1;
    bool written = false;     // the temporary is complete, synced and closed
    bool hadPrevious = false; // commit kept the earlier file under `previous`
    bool movedAside = false;  // ... by renaming it (no hard links on this file system)
    bool replaced = false;    // commit renamed the temporary onto `path`
};

std::string inQuotes(const std::string& s)
{
    return "'" + s + "'";
}

// A sibling of `path` in the same folder (so renames between them are atomic), hidden and named
// so that it is recognisably pipetile's and tied to exactly one target.
std::string sibling(const std::string& path, const char* suffix)
{
    const std::filesystem::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + suffix)).string();
}

// The system's reason, with what to do where the cause is the user's to fix.
std::string reason(int error)
{
    std::string text = std::strerror(error);
    if (error == ENOSPC || error == EDQUOT) text += "; free some space or write elsewhere";
    if (error == EFBIG) text += "; the file size limit (ulimit -f) is too small for it";
    if (error == EROFS || error == EACCES || error == EPERM) text += "; check that the folder is writable";
    return text;
}

/// A stream buffer over a file descriptor whose every write is checked: a short or failed write
/// makes the stream bad at once (OpenMesh's and std::ofstream's writers leave that unnoticed
/// until too late, or for ever), and `error()` keeps the reason.
class CheckedFileBuffer : public std::streambuf {
public:
    explicit CheckedFileBuffer(int fd) : mFd(fd), mBuffer(1 << 16) { resetBuffer(); }
    int error() const { return mError; }

protected:
    int_type overflow(int_type c) override
    {
        if (!drain()) return traits_type::eof();
        if (!traits_type::eq_int_type(c, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }
    int sync() override { return drain() ? 0 : -1; }

private:
    void resetBuffer() { setp(mBuffer.data(), mBuffer.data() + mBuffer.size()); }
    bool drain()
    {
        const char* data = pbase();
        std::size_t left = static_cast<std::size_t>(pptr() - pbase());
        while (left > 0) {
            const ssize_t n = ::write(mFd, data, left);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                mError = n < 0 ? errno : EIO;
                return false;
            }
            data += n;
            left -= static_cast<std::size_t>(n);
        }
        resetBuffer();
        return true;
    }

    int mFd;
    std::vector<char> mBuffer;
    int mError = 0;
};

// A lock file holds the line naming its run, then, from the moment that run starts renaming, a
// NUL and its commit record (see commitRecord).
std::string readLockFile(int fd)
{
    std::string content;
    char buffer[4096];
    for (;;) {
        const ssize_t n = ::pread(fd, buffer, sizeof buffer, static_cast<off_t>(content.size()));
        if (n <= 0 || content.size() > (std::size_t(1) << 20)) return content;
        content.append(buffer, static_cast<std::size_t>(n));
    }
}

std::string readHolder(int fd)
{
    const std::string content = readLockFile(fd);
    return content.substr(0, std::min(content.find('\0'), std::size_t(512)));
}

// The commit record: every target, "+" (its temporary renamed onto it) or "-" (removed), by its
// absolute path, each ended by a NUL. Written into every target's lock file before the first
// rename, so that whichever of them the next run locks tells it the whole commit.
constexpr char kCommitTag[] = "commit";

std::string commitRecord(const std::vector<Target>& targets)
{
    std::string record = std::string(1, '\0') + kCommitTag + '\0';
    for (const Target& t : targets) {
        std::error_code ec;
        const std::filesystem::path absolute = std::filesystem::absolute(t.path, ec);
        record += (t.obsolete ? "-" : "+") + (ec ? t.path : absolute.string()) + '\0';
    }
    return record;
}

struct RecordEntry {
    bool obsolete = false;
    std::string path;
};

// The entries of the commit record in a lock file's content; none if it holds no record.
std::vector<RecordEntry> parseCommitRecord(const std::string& content)
{
    std::vector<RecordEntry> entries;
    const std::size_t holderEnd = content.find('\0');
    if (holderEnd == std::string::npos) return entries;
    std::vector<std::string> fields;
    for (std::size_t at = holderEnd + 1; at < content.size();) {
        const std::size_t end = content.find('\0', at);
        if (end == std::string::npos) return {}; // cut short: the record was being written, no rename was done
        fields.push_back(content.substr(at, end - at));
        at = end + 1;
    }
    if (fields.empty() || fields.front() != kCommitTag) return entries;
    for (std::size_t k = 1; k < fields.size(); ++k)
        if (fields[k].size() > 1 && (fields[k][0] == '+' || fields[k][0] == '-'))
            entries.push_back({fields[k][0] == '-', fields[k].substr(1)});
    return entries;
}

// Writes `content` as the whole of the lock file `fd`, synced if `sync` (a commit record must
// outlast a crash); false (errno set) if it cannot.
bool writeLockFile(int fd, const std::string& content, bool sync)
{
    if (::ftruncate(fd, 0) != 0) return false;
    const ssize_t n = ::pwrite(fd, content.data(), content.size(), 0);
    if (n < 0) return false;
    if (static_cast<std::size_t>(n) != content.size()) {
        errno = ENOSPC;
        return false;
    }
    return !sync || ::fsync(fd) == 0;
}

bool sameInode(int fd, const std::string& path)
{
    struct stat open, named;
    return ::fstat(fd, &open) == 0 && ::stat(path.c_str(), &named) == 0 && open.st_dev == named.st_dev &&
           open.st_ino == named.st_ino;
}

// Takes the target's lock without waiting, and returns in `previous` what the lock file held (a
// killed run's commit record, maybe). A lock file unlinked by its last holder between our open
// and flock is not the lock any more: open again.
int acquireLock(const Target& target, std::string& previous)
{
    for (;;) {
        const int fd = ::open(target.lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
        if (fd < 0)
            throw Error(inQuotes(target.path) + ": cannot create its lock file " + inQuotes(target.lock) + " (" +
                        reason(errno) + ")");
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
            const int error = errno;
            const std::string other = readHolder(fd);
            ::close(fd);
            if (error == EWOULDBLOCK)
                throw Error(inQuotes(target.path) + " is being written by another pipetile run (" +
                            (other.empty() ? std::string("see ") + inQuotes(target.lock) : other) +
                            "); wait for it to finish, or write elsewhere");
            throw Error(inQuotes(target.path) + ": cannot lock " + inQuotes(target.lock) + " (" + reason(error) + ")");
        }
        if (sameInode(fd, target.lock)) {
            previous = readLockFile(fd);
            return fd;
        }
        ::close(fd);
    }
}

// The mutex orders commits, abandonment and the creation of temporaries: a signal's abandonment
// never runs in the middle of a commit, and no temporary appears after it. Recursive: a thread
// that ends the process while it commits (std::terminate) abandons the other sets, not this one.
std::recursive_mutex& registryMutex()
{
    static std::recursive_mutex mutex;
    return mutex;
}

std::set<OutputSet::Impl*>& openSets()
{
    static std::set<OutputSet::Impl*> sets;
    return sets;
}

} // namespace

struct OutputSet::Impl {
    std::vector<Target> targets;
    std::string holder; // the line this run's lock files hold
    std::vector<std::string> staleRemoved, recovered;
    State state = State::Open;

    Target& find(const std::string& path);
    void lockAll();
    void releaseLocks(bool unlinkLockFiles);
    void finishInterruptedCommit(const std::vector<RecordEntry>& record);
    void removeStale();
    void announce(bool withRecord);
    void removeTemporaries();
    void replace(Target& target);
    std::string restore(std::size_t count);
};

Target& OutputSet::Impl::find(const std::string& path)
{
    for (Target& t : targets)
        if (t.path == path) return t;
    throw UsageError("OutputSet: " + inQuotes(path) + " is not one of the set's targets");
}

void OutputSet::Impl::lockAll()
{
    std::vector<std::vector<RecordEntry>> records;
    try {
        for (Target& t : targets) {
            std::string previous;
            t.lockFd = acquireLock(t, previous);
            std::vector<RecordEntry> record = parseCommitRecord(previous);
            if (!record.empty()) records.push_back(std::move(record));
        }
    } catch (...) {
        releaseLocks(true);
        throw;
    }
    // Holding the locks, nobody else can be writing these: a killed run left the records.
    for (const std::vector<RecordEntry>& record : records) finishInterruptedCommit(record);
}

// A run killed while renaming left its set half old, half new; its temporaries were complete
// (every one is written, synced and closed before the record), so the commit is finished as it
// would have been: each temporary left goes onto its target, each obsolete target goes, and the
// earlier files kept aside are removed. Targets not in this set are locked for the while; one
// that another run holds was finished by that run when it took it.
void OutputSet::Impl::finishInterruptedCommit(const std::vector<RecordEntry>& record)
{
    for (const RecordEntry& entry : record) {
        Target t;
        t.path = entry.path;
        t.temporary = sibling(entry.path, ".pipetile-tmp");
        t.previous = sibling(entry.path, ".pipetile-old");
        t.lock = sibling(entry.path, ".pipetile-lock");
        bool ours = false;
        for (const Target& own : targets) {
            std::error_code ec;
            ours = ours || std::filesystem::absolute(own.path, ec) == std::filesystem::path(entry.path);
        }
        int fd = -1;
        if (!ours) {
            std::string ignored;
            try {
                fd = acquireLock(t, ignored);
            } catch (const Error&) {
                continue;
            }
        }
        const bool done =
            entry.obsolete ? ::unlink(t.path.c_str()) == 0 : ::rename(t.temporary.c_str(), t.path.c_str()) == 0;
        if (done) recovered.push_back(t.path);
        ::unlink(t.previous.c_str());
        if (fd >= 0) {
            ::unlink(t.lock.c_str());
            ::close(fd);
        }
    }
}

// Writes this run's line into its lock files, for a second run to name it, and while it renames,
// the commit record after it (false, errno set, if a record cannot be written).
void OutputSet::Impl::announce(bool withRecord)
{
    const std::string content = withRecord ? holder + commitRecord(targets) : holder;
    for (const Target& t : targets) {
        if (writeLockFile(t.lockFd, content, withRecord) || !withRecord)
            continue; // the line only informs: a full disk must not stop the run
        throw Error(inQuotes(t.path) + ": cannot record the commit in " + inQuotes(t.lock) + " (" + reason(errno) +
                    ")");
    }
}

void OutputSet::Impl::releaseLocks(bool unlinkLockFiles)
{
    // Unlinked while still held, so a run that opened the old file sees it is gone (sameInode).
    for (Target& t : targets) {
        if (t.lockFd < 0) continue;
        if (unlinkLockFiles) ::unlink(t.lock.c_str());
        ::close(t.lockFd);
        t.lockFd = -1;
    }
}

void OutputSet::Impl::removeStale()
{
    // Holding the lock, nobody else can be writing these: a run killed before it renamed left a
    // temporary. An earlier file kept aside without a record (an older pipetile's commit) is put
    // back where its target is gone, never lost.
    for (const Target& t : targets) {
        if (::unlink(t.temporary.c_str()) == 0) staleRemoved.push_back(t.temporary);
        struct stat existing;
        if (::lstat(t.path.c_str(), &existing) != 0 && errno == ENOENT &&
            ::rename(t.previous.c_str(), t.path.c_str()) == 0)
            recovered.push_back(t.path);
        else if (::unlink(t.previous.c_str()) == 0)
            staleRemoved.push_back(t.previous);
    }
}

void OutputSet::Impl::removeTemporaries()
{
    for (Target& t : targets) {
        ::unlink(t.temporary.c_str());
        t.written = false;
    }
}

// Puts one temporary in place, keeping the earlier file under `previous` for a rollback: a second
// hard link where the file system has them (the target never disappears), else a rename.
void OutputSet::Impl::replace(Target& t)
{
    if (t.obsolete) {
        // Kept aside like an earlier file, so that a rollback puts it back.
        if (::rename(t.path.c_str(), t.previous.c_str()) == 0)
            t.hadPrevious = t.movedAside = true;
        else if (errno != ENOENT)
            throw Error(inQuotes(t.path) + ": cannot remove it, a level of an earlier run with more levels (" +
                        reason(errno) + ")");
        return;
    }
    struct stat existing;
    if (::lstat(t.path.c_str(), &existing) == 0) {
        if (!S_ISREG(existing.st_mode) && !S_ISLNK(existing.st_mode))
            throw Error(inQuotes(t.path) + ": cannot replace it, it is " +
                        (S_ISDIR(existing.st_mode) ? "a folder" : "not a regular file") +
                        "; remove it or choose another name");
        if (::link(t.path.c_str(), t.previous.c_str()) != 0) {
            if (::rename(t.path.c_str(), t.previous.c_str()) != 0)
                throw Error(inQuotes(t.path) + ": cannot keep its earlier content aside (" + reason(errno) + ")");
            t.movedAside = true;
        }
        t.hadPrevious = true;
    } else if (errno != ENOENT) {
        throw Error(inQuotes(t.path) + ": cannot look at it (" + reason(errno) + ")");
    }
    if (::rename(t.temporary.c_str(), t.path.c_str()) != 0)
        throw Error(inQuotes(t.path) + ": cannot rename " + inQuotes(t.temporary) + " onto it (" + reason(errno) + ")");
    t.replaced = true;
}

// Undoes the first `count` targets' replacements, and a partial one of the next; returns what
// could not be restored (empty when all was).
std::string OutputSet::Impl::restore(std::size_t count)
{
    std::string failed;
    for (std::size_t k = 0; k <= count && k < targets.size(); ++k) {
        Target& t = targets[k];
        if (!t.hadPrevious) {
            if (t.replaced && ::unlink(t.path.c_str()) != 0) failed += " " + inQuotes(t.path);
        } else if (t.replaced || t.movedAside) {
            if (::rename(t.previous.c_str(), t.path.c_str()) != 0)
                failed += " " + inQuotes(t.path) + " (its earlier content is in " + inQuotes(t.previous) + ")";
        } else {
            ::unlink(t.previous.c_str()); // the target still is the earlier file
        }
        t.hadPrevious = t.movedAside = t.replaced = false;
    }
    return failed;
}

namespace {

// Makes the renames durable: a folder's entries reach the disk only when the folder is synced.
void syncFolders(const std::vector<Target>& targets)
{
    std::set<std::string> folders;
    for (const Target& t : targets) {
        const std::filesystem::path folder = std::filesystem::path(t.path).parent_path();
        folders.insert(folder.empty() ? "." : folder.string());
    }
    for (const std::string& folder : folders) {
        const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd < 0) throw Error("folder " + inQuotes(folder) + ": cannot open it to sync (" + reason(errno) + ")");
        const int synced = ::fsync(fd), error = errno;
        ::close(fd);
        if (synced != 0 && error != EINVAL) // EINVAL: the file system does not sync folders
            throw Error("folder " + inQuotes(folder) + ": cannot sync it (" + reason(error) + ")");
    }
}

// Writes through `write` into `fd`, then flushes, fsyncs and closes it, checking each step;
// closes `fd` whatever happens.
void writeChecked(int fd, const std::string& target, const std::function<void(std::ostream&)>& write)
{
    auto fail = [&](const std::string& why) {
        if (fd >= 0) ::close(fd);
        throw Error(inQuotes(target) + ": cannot write it (" + why + ")");
    };
    CheckedFileBuffer buffer(fd);
    std::ostream out(&buffer);
    out.exceptions(std::ios::badbit);
    try {
        write(out);
        out.flush();
    } catch (const std::ios_base::failure&) {
        fail(reason(buffer.error() ? buffer.error() : EIO));
    } catch (const Error& e) {
        fail(e.what());
    } catch (const std::exception& e) {
        fail(e.what());
    }
    if (buffer.error()) fail(reason(buffer.error())); // a writer that swallowed the stream's exception
    if (::fsync(fd) != 0) fail(reason(errno));
    const int closed = ::close(fd);
    fd = -1;
    if (closed != 0) fail(reason(errno));
}

} // namespace

OutputSet::OutputSet(const std::vector<std::string>& targets, const std::string& owner,
                     const std::vector<std::string>& obsolete)
    : mImpl(std::make_unique<Impl>())
{
    std::set<std::string> seen;
    // The obsolete files first: the commit removes them before it renames, so a rename that fails
    // puts them back too.
    std::vector<std::string> paths = obsolete;
    paths.insert(paths.end(), targets.begin(), targets.end());
    for (const std::string& path : paths) {
        if (!seen.insert(path).second)
            throw Error(inQuotes(path) + " is named twice as an output; give each output its own name");
        const std::filesystem::path folder = std::filesystem::path(path).parent_path();
        std::error_code ec;
        if (!folder.empty() && !std::filesystem::is_directory(folder, ec))
            throw Error(inQuotes(path) + ": the folder " + inQuotes(folder.string()) +
                        " does not exist; create it first");
        Target t;
        t.path = path;
        t.temporary = sibling(path, ".pipetile-tmp");
        t.previous = sibling(path, ".pipetile-old");
        t.lock = sibling(path, ".pipetile-lock");
        t.obsolete = mImpl->targets.size() < obsolete.size();
        mImpl->targets.push_back(t);
    }
    mImpl->holder = "pid " + std::to_string(::getpid()) + (owner.empty() ? "" : ": " + owner);
    // Locked and registered in one step: a signal's abandonment sees every lock file it made.
    std::lock_guard<std::recursive_mutex> guard(registryMutex());
    mImpl->lockAll();
    mImpl->removeStale();
    mImpl->announce(false);
    openSets().insert(mImpl.get());
}

OutputSet::~OutputSet()
{
    std::lock_guard<std::recursive_mutex> guard(registryMutex());
    openSets().erase(mImpl.get());
    if (mImpl->state == State::Open) mImpl->removeTemporaries();
    // Abandoned lock files are already unlinked; another run may own a new one of that name.
    mImpl->releaseLocks(mImpl->state != State::Abandoned);
}

void OutputSet::write(const std::string& target, const std::function<void(std::ostream&)>& write)
{
    Target& t = mImpl->find(target);
    if (t.obsolete) throw UsageError("OutputSet: " + inQuotes(target) + " is to be removed, not written");
    int fd = -1;
    {
        std::lock_guard<std::recursive_mutex> guard(registryMutex());
        if (mImpl->state != State::Open) throw Error(inQuotes(target) + ": not written, the run was interrupted");
        t.written = false;
        fd = ::open(t.temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        if (fd < 0)
            throw Error(inQuotes(target) + ": cannot create " + inQuotes(t.temporary) + " (" + reason(errno) + ")");
    }
    try {
        writeChecked(fd, target, write);
    } catch (...) {
        std::lock_guard<std::recursive_mutex> guard(registryMutex());
        if (mImpl->state == State::Open) ::unlink(t.temporary.c_str());
        throw;
    }
    t.written = true;
}

void OutputSet::commit()
{
    std::lock_guard<std::recursive_mutex> guard(registryMutex());
    if (mImpl->state != State::Open) throw Error("outputs not written: the run was interrupted");
    for (const Target& t : mImpl->targets)
        if (!t.obsolete && !t.written)
            throw UsageError("OutputSet: " + inQuotes(t.path) + " was not written before commit");
    // From the record on, a process killed here leaves what the next run needs to finish the commit.
    mImpl->state = State::Committing;
    std::size_t done = 0;
    auto rollBack = [&] {
        const std::string failed = mImpl->restore(done);
        mImpl->removeTemporaries();
        mImpl->announce(false);
        mImpl->state = State::Open;
        return failed;
    };
    try {
        mImpl->announce(true);
        for (; done < mImpl->targets.size(); ++done) mImpl->replace(mImpl->targets[done]);
        syncFolders(mImpl->targets);
    } catch (const Error& e) {
        const std::string failed = rollBack();
        throw Error(std::string(e.what()) + "; nothing of this run was kept" +
                    (failed.empty() ? ", the earlier files are as they were" : ", but could not restore" + failed));
    } catch (...) {
        rollBack(); // out of memory, say: the caller tells it
        throw;
    }
    for (Target& t : mImpl->targets) {
        if (t.hadPrevious) ::unlink(t.previous.c_str());
        t.hadPrevious = t.movedAside = t.replaced = false;
    }
    mImpl->state = State::Committed;
}

const std::vector<std::string>& OutputSet::staleRemoved() const
{
    return mImpl->staleRemoved;
}

const std::vector<std::string>& OutputSet::recovered() const
{
    return mImpl->recovered;
}

void abandonOutputs()
{
    std::lock_guard<std::recursive_mutex> guard(registryMutex());
    for (OutputSet::Impl* set : openSets()) {
        if (set->state != State::Open) continue;
        set->state = State::Abandoned;
        for (const Target& t : set->targets) {
            if (t.lockFd < 0) continue; // not ours: another run's lock file and temporary
            ::unlink(t.temporary.c_str());
            ::unlink(t.lock.c_str());
        }
    }
}

} // namespace pipetile
