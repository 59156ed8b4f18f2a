// pipetile — output_set: the files a run writes, as one transaction.
//
// Every output goes first to a temporary sibling, `.NAME.pipetile-tmp`, and every step of writing it
// is checked (each write, the flush, fsync, close). Only when all of them are written are they
// renamed into place, in order; if one cannot be, the ones renamed before it get their earlier
// content back. A run that fails or is abandoned therefore leaves the folder as it found it.
//
// A set may also name obsolete files, which the commit removes (kept aside until it ends, and put
// back if it fails): the levels an earlier run with more levels left.
//
// Each output is locked (flock on `.NAME.pipetile-lock`, which names the run holding it) from the
// moment the set is opened, before any work: a second run writing the same file fails at once and
// says which run has it. Whoever holds an output's lock owns its temporaries, so temporaries found
// by the run that takes the lock were left by a killed run (SIGKILL, a crash, power loss):
// - killed before its commit: its temporaries are incomplete, and are removed;
// - killed during its commit, with some targets renamed and others not: before the first rename
//   the commit writes its record (every target, and whether it is replaced or removed) into each
//   target's lock file, synced, while every temporary is complete. The run that next locks any of
//   those targets finishes that commit (renames the temporaries left, removes what was to go, and
//   the earlier files kept aside), so the set is wholly the killed run's, never a mix of two.
#pragma once

#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace pipetile {

/// The outputs of one run, written all or nothing. Stateful: open, write each target, commit.
/// Destroying a set that was not committed removes its temporaries; the targets stay as they were.
class OutputSet {
public:
    /// Locks every target and every obsolete file, finishes a commit a killed run left half done
    /// among them, and removes the temporaries a killed run left. `owner` says who writes (for
    /// example the command line); a second run is told it, with this process id. `obsolete`:
    /// files the commit removes (not written; none of `targets`).
    /// @throw Error if another run holds a target, or a target's folder is missing or not writable.
    explicit OutputSet(const std::vector<std::string>& targets, const std::string& owner = "",
                       const std::vector<std::string>& obsolete = {});
    ~OutputSet();
    OutputSet(const OutputSet&) = delete;
    OutputSet& operator=(const OutputSet&) = delete;

    /// Writes `target` (one of the set's) to its temporary file through `write`, then flushes,
    /// fsyncs and closes it. The stream throws on the first byte that cannot be written.
    /// @throw Error naming the target and the reason (no space left, file too large, ...) if any
    /// step fails, or if `write` throws; the temporary is removed.
    void write(const std::string& target, const std::function<void(std::ostream&)>& write);

    /// Removes the obsolete files, renames every temporary onto its target, in the order the
    /// targets were given, and syncs their folders. A target that exists is kept under `.NAME.pipetile-old` until all are in
    /// place; if one rename fails, those done are undone and nothing of this run remains.
    /// @throw Error naming the target that could not be replaced, and why.
    void commit();

    /// Temporary files of killed runs that opening the set removed (for a note to the user).
    const std::vector<std::string>& staleRemoved() const;

    /// Files that opening the set put in place or removed to finish a commit a killed run left
    /// half done (for a note to the user).
    const std::vector<std::string>& recovered() const;

    struct Impl;

private:
    std::unique_ptr<Impl> mImpl;
};

/// Abandons every output set of this process that is not committed: removes their temporary
/// files and lock files, so that the process can end on a signal leaving the outputs as they were
/// before the run. A commit in progress is finished first. Later writes to those sets fail.
/// For a thread that waits for signals (sigwait); it is not async-signal-safe.
void abandonOutputs();

} // namespace pipetile
