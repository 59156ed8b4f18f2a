// pipetile — errors. The library reports wrong input by throwing; it never prints or exits.
// Everything it throws derives from pipetile::Error, except std::bad_alloc when memory runs out
// (and what a caller's own callback throws, which passes through).
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pipetile {

/// A setting of a request that a message asks the user to change. Library messages name settings
/// in words ("lower the slice spacing"); a front end adds its own name for them (the CLI its
/// flags, Python its keywords), since the library cannot know how it was called.
enum class Setting {
    Grid,    // VolumeOptions::gridName
    Iso,     // VolumeOptions::iso
    Spacing, // SliceOptions::spacingVoxels
    Rays,    // MeshOptions::baseRays
    Levels,  // MeshOptions::levels
    Threads, // MeshOptions::threads
};

/// Base of every exception pipetile throws for bad input or an impossible request. The message
/// names the file or grid at fault and what the user can do about it; `settings()` lists the
/// settings it asks to change, in the order it names them.
class Error : public std::runtime_error {
public:
    explicit Error(const std::string& message, std::vector<Setting> settings = {})
        : std::runtime_error(message),
          mSettings(std::move(settings))
    {
    }
    const std::vector<Setting>& settings() const { return mSettings; }

private:
    std::vector<Setting> mSettings;
};

/// A request that can never be satisfied as given (absurd parameters, or a call that breaks a
/// function's stated precondition); the CLI maps it to exit 2.
class UsageError : public Error {
public:
    using Error::Error;
};

/// A broken internal invariant: a bug in pipetile, never the input's fault. The message names the
/// source line and the condition; please report it with the input.
class InternalError : public Error {
public:
    using Error::Error;
};

/// The setting's short name: "grid", "iso", "spacing", "rays", "levels" or "threads".
const char* toString(Setting setting);

/// The error's message followed by the settings it names, each as prefix + toString + suffix:
/// withSettings(e, "--", "") gives "...; lower the spacing (--spacing)" for a command line,
/// withSettings(e, "", "=") "(spacing=)" for keyword arguments. The message alone if it names none.
std::string withSettings(const Error& error, const char* prefix, const char* suffix);

namespace detail {
[[noreturn]] void throwInternalError(const char* condition, const char* what, const char* file, int line);
} // namespace detail

} // namespace pipetile

/// Checks an internal invariant whatever NDEBUG says: throws InternalError naming `what` (a string
/// literal saying what broke), the condition and file:line if it does not hold. One predictable
/// branch where it holds, and the message is built only when it does not: cheap in hot loops.
#define PIPETILE_ASSERT(condition, what)                                                                               \
    do {                                                                                                               \
        if (__builtin_expect(!(condition), 0))                                                                         \
            ::pipetile::detail::throwInternalError(#condition, what, __FILE__, __LINE__);                              \
    } while (false)
