// pipetile — progress on stderr.

#include "progress.h"

#include <cstdio>

namespace pipetile::tools {

namespace {

// "1:05" or "12 s": the time left, as a person reads it.
std::string duration(double seconds)
{
    char text[32];
    const long s = static_cast<long>(seconds + 0.5);
    if (s < 60)
        std::snprintf(text, sizeof text, "%ld s", s);
    else
        std::snprintf(text, sizeof text, "%ld:%02ld", s / 60, s % 60);
    return text;
}

} // namespace

Progress::Progress(int total, std::string unit, bool terminal)
    : mTotal(total),
      mUnit(std::move(unit)),
      mTerminal(terminal)
{
}

Progress::~Progress()
{
    if (mBarShown) std::fputc('\n', stderr);
}

void Progress::step(const std::string& what, bool failed)
{
    ++mDone;
    if (failed) ++mFailed;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - mStart).count();
    const double rate = seconds > 0.0 ? mDone / seconds : 0.0;
    const std::string left = rate > 0.0 ? duration((mTotal - mDone) / rate) : "?";
    if (mTerminal) {
        constexpr int width = 30;
        const int filled = mTotal > 0 ? width * mDone / mTotal : width;
        const std::string failures = mFailed ? ", " + std::to_string(mFailed) + " failed" : "";
        std::fprintf(stderr, "\r[%s%s] %d/%d %s%s, %.2f/s, %s left\x1b[K", std::string(filled, '#').c_str(),
                     std::string(width - filled, '-').c_str(), mDone, mTotal, mUnit.c_str(), failures.c_str(), rate,
                     left.c_str());
        mBarShown = true;
    } else {
        std::fprintf(stderr, "pipetile: %s %s (%d/%d %s, %.2f/s, %s left)\n", what.c_str(), failed ? "failed" : "done",
                     mDone, mTotal, mUnit.c_str(), rate, left.c_str());
    }
    std::fflush(stderr);
}

void Progress::print(const std::string& line, std::FILE* stream)
{
    if (mBarShown) std::fputs("\r\x1b[K", stderr);
    mBarShown = false;
    std::fflush(stderr);
    std::fprintf(stream, "%s\n", line.c_str());
    std::fflush(stream);
}

} // namespace pipetile::tools
