// pipetile — frame sequences: patterns, ranges and the aggregate report.

#include "sequence.h"

#include <pipetile/error.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <set>
#include <system_error>

namespace pipetile::tools {

using nlohmann::json;

namespace {

struct Token {
    std::size_t at = std::string::npos, length = 0;
    int width = 0;
};

// The digits of `text` from `at` as a number (at most 3 digits: a padding), and how many.
std::pair<int, std::size_t> smallNumber(const std::string& text, std::size_t at)
{
    std::size_t end = at;
    while (end < text.size() && end - at < 3 && std::isdigit(static_cast<unsigned char>(text[end]))) ++end;
    return {end > at ? std::stoi(text.substr(at, end - at)) : 0, end - at};
}

// The first frame token in `text`: ####, $F / $F4, %d / %04d.
Token findToken(const std::string& text)
{
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] == '#') {
            std::size_t end = i;
            while (end < text.size() && text[end] == '#') ++end;
            return {i, end - i, static_cast<int>(end - i)};
        }
        if (text.compare(i, 2, "$F") == 0) {
            const auto [width, digits] = smallNumber(text, i + 2);
            return {i, 2 + digits, width};
        }
        if (text[i] == '%') {
            std::size_t at = i + 1;
            const bool zero = at < text.size() && text[at] == '0';
            const auto [width, digits] = smallNumber(text, at + (zero ? 1 : 0));
            const std::size_t d = at + (zero ? 1 : 0) + digits;
            if (d < text.size() && text[d] == 'd' && (zero || digits == 0)) return {i, d + 1 - i, zero ? width : 0};
        }
    }
    return {};
}

} // namespace

std::optional<FramePattern> FramePattern::parse(const std::string& text)
{
    const Token token = findToken(text);
    if (token.at == std::string::npos) return std::nullopt;
    FramePattern pattern;
    pattern.mText = text;
    pattern.mPrefix = text.substr(0, token.at);
    pattern.mSuffix = text.substr(token.at + token.length);
    pattern.mWidth = token.width;
    return pattern;
}

std::string FramePattern::path(int frame) const
{
    std::string digits = std::to_string(frame);
    if (static_cast<int>(digits.size()) < mWidth)
        digits.insert(0, static_cast<std::size_t>(mWidth) - digits.size(), '0');
    return mPrefix + digits + mSuffix;
}

std::vector<int> FramePattern::existingFrames() const
{
    if (mSuffix.find('/') != std::string::npos)
        throw UsageError("'" + mText +
                         "': the frame number is in a folder's name; give --frames A-B to name the frames");
    const std::string folder = mPrefix.substr(0, mPrefix.rfind('/') + 1); // with its '/', or empty
    const std::string namePrefix = mPrefix.substr(folder.size());
    std::set<int> frames;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(folder.empty() ? "." : folder, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.size() <= namePrefix.size() + mSuffix.size() || name.compare(0, namePrefix.size(), namePrefix) != 0 ||
            name.compare(name.size() - mSuffix.size(), mSuffix.size(), mSuffix) != 0)
            continue;
        const std::string digits = name.substr(namePrefix.size(), name.size() - namePrefix.size() - mSuffix.size());
        if (digits.size() > 9 || !std::all_of(digits.begin(), digits.end(),
                                              [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
            continue;
        const int frame = std::stoi(digits);
        // Only the spelling path() gives: `smoke.0012.vdb` is frame 12 of ####, `smoke.12.vdb` is not.
        if (path(frame) == folder + name) frames.insert(frame);
    }
    return {frames.begin(), frames.end()};
}

std::vector<int> parseFrameRange(const std::string& spec)
{
    const auto fail = [&](const std::string& why) {
        return UsageError("--frames '" + spec + "': " + why +
                          "; write A-B or A-B:STEP (frames 0 or more), or one frame A");
    };
    const auto number = [&](const std::string& text) {
        if (text.empty() || text.size() > 9 ||
            !std::all_of(text.begin(), text.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
            throw fail("'" + text + "' is not a frame number");
        return std::stoi(text);
    };
    const std::size_t colon = spec.find(':');
    const std::string range = spec.substr(0, colon);
    const int step = colon == std::string::npos ? 1 : number(spec.substr(colon + 1));
    const std::size_t dash = range.find('-');
    const int first = number(range.substr(0, dash));
    const int last = dash == std::string::npos ? first : number(range.substr(dash + 1));
    if (last < first) throw fail("the last frame comes before the first");
    if (step < 1) throw fail("the step must be 1 or more");
    std::vector<int> frames;
    for (long long f = first; f <= last; f += step) frames.push_back(static_cast<int>(f));
    return frames;
}

std::string frameError(int frame, const std::string& what)
{
    return "frame " + std::to_string(frame) + ": " + what;
}

json sequenceReport(const std::string& input, const std::string& output, const std::vector<FrameOutcome>& frames,
                    double seconds)
{
    long long vertices = 0, triangles = 0;
    double frameSeconds = 0.0;
    int meshed = 0, skipped = 0;
    json failures = json::array(), lines = json::array();
    for (const FrameOutcome& f : frames) {
        json line = {{"frame", f.frame}, {"input", f.input}, {"status", f.status}};
        if (f.status == "meshed") {
            ++meshed;
            frameSeconds += f.report["seconds"].get<double>();
            line["seconds"] = f.report["seconds"];
            for (const json& level : f.report["levels"]) {
                vertices += level["vertices"].get<long long>();
                triangles += level["triangles"].get<long long>();
            }
        } else if (f.status == "skipped") {
            ++skipped;
        } else {
            failures.push_back({{"frame", f.frame}, {"input", f.input}, {"error", f.error}});
            line["error"] = f.error;
        }
        lines.push_back(line);
    }
    return {{"input", input},
            {"output", output},
            {"frames", frames.size()},
            {"meshed", meshed},
            {"skipped", skipped},
            {"failed", failures.size()},
            {"failures", failures},
            {"totals", {{"vertices", vertices}, {"triangles", triangles}, {"seconds", frameSeconds}}},
            {"seconds", seconds},
            {"per_frame", lines}};
}

} // namespace pipetile::tools
