// pipetile — internal (namespace detail, not part of the API): write a file through a temporary sibling and a rename, so a failure never
// leaves half a file where a good one was expected.
#pragma once

#include <pipetile/error.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <functional>
#include <string>

namespace pipetile::detail {

/// A temporary path in the same folder as `target` (so the rename is atomic), keeping the
/// extension, because writers such as OpenMesh pick the format from it.
inline std::filesystem::path temporarySibling(const std::filesystem::path& target)
{
    static std::atomic<int> counter{0};
    std::filesystem::path tmp = target.parent_path();
    tmp /= "." + target.stem().string() + ".tmp" + std::to_string(::getpid()) + "_" +
           std::to_string(counter++) + target.extension().string();
    return tmp;
}

/// Calls `write(temporaryPath)` and renames the result onto `target`; on any failure the temporary
/// file is removed and Error is thrown with `what` naming the target.
inline void writeAtomically(const std::string& target, const std::function<void(const std::string&)>& write)
{
    const std::filesystem::path tmp = temporarySibling(target);
    try {
        write(tmp.string());
        std::filesystem::rename(tmp, target);
    } catch (const Error&) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw;
    } catch (const std::exception& e) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw Error("'" + target + "': cannot write (" + e.what() + "); check that the folder exists and is writable");
    }
}

} // namespace pipetile::detail
