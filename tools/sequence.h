// pipetile — frame sequences: file names with a frame number (`smoke.####.vdb`, Houdini's
// `smoke.$F4.vdb`, printf's `smoke.%04d.vdb`), frame ranges (`1001-1100:2`) and the aggregate
// report of a sequence. Shared by the CLI's batch and pipetile.dask, so both name frames, files
// and failures alike.
#pragma once

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace pipetile::tools {

/// A path with one frame token: `#` repeated (as many digits, zero-padded), `$F` or `$F<n>`
/// (Houdini: unpadded, or n digits), `%d` or `%0<n>d` (printf). A frame wider than its padding
/// is written in full (frame 12345 of `####` is `12345`).
class FramePattern {
public:
    /// The pattern in `text`, or nothing if it holds no frame token.
    static std::optional<FramePattern> parse(const std::string& text);

    const std::string& text() const { return mText; }
    /// The path of `frame`.
    std::string path(int frame) const;
    /// The frames whose files exist, ascending: names in the pattern's folder that are the
    /// pattern with a frame number in it, written as path() writes it.
    /// @throw UsageError if the token is in the folder, not the file name.
    std::vector<int> existingFrames() const;

private:
    std::string mText, mPrefix, mSuffix;
    int mWidth = 0; // digits the frame is padded to with zeros (0: none)
};

/// Frames from `A-B` (both included), `A-B:step` or `A`; frames are 0 or more.
/// @throw UsageError naming `spec` if it is none of these, B < A, or step < 1.
std::vector<int> parseFrameRange(const std::string& spec);

/// What became of one frame of a sequence.
struct FrameOutcome {
    int frame = 0;
    std::string input;
    std::string status;    // "meshed", "skipped" (its outputs existed) or "failed"
    std::string error;     // failed: the one-line message, naming the frame (frameError)
    nlohmann::json report; // meshed: the frame's report (meshFrame's)
};

/// The message of a failed frame: "frame N: <what went wrong, naming the file>".
std::string frameError(int frame, const std::string& what);

/// The aggregate report of a sequence: frames, how many were meshed, skipped and failed, each
/// failure, the totals of the meshed frames (vertices and triangles over all levels, seconds
/// summed), the wall time `seconds`, and one line per frame.
nlohmann::json sequenceReport(const std::string& input, const std::string& output,
                              const std::vector<FrameOutcome>& frames, double seconds);

} // namespace pipetile::tools
