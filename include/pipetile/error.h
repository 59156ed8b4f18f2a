// pipetile — errors. The library reports wrong input by throwing; it never prints or exits.
#pragma once

#include <stdexcept>
#include <string>

namespace pipetile {

/// Base of every exception pipetile throws for bad input or an impossible request. The message
/// names the file or grid at fault and what the user can do about it; the CLI prints it as is.
class Error : public std::runtime_error {
public:
    explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// A request that can never be satisfied as given (absurd parameters); the CLI maps it to exit 2.
class UsageError : public Error {
public:
    explicit UsageError(const std::string& message) : Error(message) {}
};

} // namespace pipetile
