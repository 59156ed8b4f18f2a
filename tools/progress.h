// pipetile — progress on stderr: a bar with the count done, the rate and the time left when
// stderr is a terminal, one plain line per step otherwise (a log, a CI job, a render farm).
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace pipetile::tools {

/// Progress through `total` steps of one kind ("frames", "levels"). Stateful: step() after each.
class Progress {
public:
    /// `terminal`: draw a bar that redraws itself in place (else plain lines).
    Progress(int total, std::string unit, bool terminal);
    ~Progress(); // ends the bar's line

    /// One more step done; `what` says which ("frame 1005", "level 2"), `failed` if it failed.
    void step(const std::string& what, bool failed = false);
    /// A line (a warning on stderr, a frame's summary on stdout) that the bar must not draw over.
    void print(const std::string& line, std::FILE* stream = stderr);

private:
    int mTotal, mDone = 0, mFailed = 0;
    std::string mUnit;
    bool mTerminal;
    bool mBarShown = false;
    std::chrono::steady_clock::time_point mStart = std::chrono::steady_clock::now();
};

} // namespace pipetile::tools
