// pipetile — errors: the one place that builds an internal error's message (PIPETILE_ASSERT).

#include <pipetile/error.h>

#include <cstring>

namespace pipetile {

const char* toString(Setting setting)
{
    switch (setting) {
    case Setting::Grid: return "grid";
    case Setting::Iso: return "iso";
    case Setting::Spacing: return "spacing";
    case Setting::Rays: return "rays";
    case Setting::Levels: return "levels";
    case Setting::Threads: return "threads";
    }
    return "?";
}

std::string withSettings(const Error& error, const char* prefix, const char* suffix)
{
    std::string message = error.what();
    const std::vector<Setting>& settings = error.settings();
    for (std::size_t i = 0; i < settings.size(); ++i)
        message += (i == 0 ? " (" : ", ") + (prefix + std::string(toString(settings[i]))) + suffix;
    return settings.empty() ? message : message + ")";
}

namespace detail {

void throwInternalError(const char* condition, const char* what, const char* file, int line)
{
    // The file's name alone: the build's absolute paths mean nothing to whoever reads the report.
    const char* slash = std::strrchr(file, '/');
    throw InternalError(std::string("internal invariant broken: ") + what + " (" + (slash ? slash + 1 : file) + ":" +
                        std::to_string(line) + ": " + condition + ")");
}

} // namespace detail

} // namespace pipetile
