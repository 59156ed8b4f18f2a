// pipetile — libFuzzer harness: arbitrary bytes read as a .vdb file, then meshed when they pass.
//
// pipetile::Error (and its UsageError) is the documented answer to a bad file; any other exception
// escapes to libFuzzer, which reports it like a crash, as it does sanitizer reports and timeouts.
// Run with -rss_limit_mb=2048 (see .ci/fuzz.sh): running out of memory on a small file is a
// finding too.
//
// OpenVDB sizes some buffers from numbers in the file (bloscFromStream allocates the compressed
// size it reads; string metadata is resized, and zero-filled, to the length it reads). Outside the
// fuzzer an absurd size makes `new` throw std::bad_alloc, which readVolume reports as
// pipetile::Error; under AddressSanitizer `new` aborts instead, and sizes that do fit pile up past
// the memory limit. So this harness replaces the global operator new with one that throws
// std::bad_alloc above 64 MiB: inputs are at most 24 KB and meshing them (within the budget
// below) needs far less in one piece, so a bigger request comes from a size read out of a damaged
// file, and gets what a machine short of memory would answer.

#include <pipetile/error.h>
#include <pipetile/multires.h>
#include <pipetile/volume.h>

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>

#include <stdlib.h>
#include <unistd.h>

namespace {

constexpr std::size_t kMaxAllocation = std::size_t(64) << 20;

void* allocate(std::size_t size, std::size_t alignment = 0)
{
    if (size <= kMaxAllocation) {
        void* p = nullptr;
        if (alignment > alignof(std::max_align_t)) {
            if (posix_memalign(&p, alignment, size ? size : 1) != 0) p = nullptr;
        } else {
            p = std::malloc(size ? size : 1);
        }
        if (p) return p;
    }
    throw std::bad_alloc();
}

void* allocateNoThrow(std::size_t size, std::size_t alignment = 0) noexcept
{
    try {
        return allocate(size, alignment);
    } catch (const std::bad_alloc&) {
        return nullptr;
    }
}

} // namespace

// Every form, so that every allocation of the process (libstdc++ and OpenVDB included) goes through
// malloc and free, and AddressSanitizer sees matching pairs. (This gives up its new/delete[]
// mismatch check in this binary; fuzz_contour and the sanitizer test suite keep it.)
void* operator new(std::size_t size)
{
    return allocate(size);
}
void* operator new[](std::size_t size)
{
    return allocate(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept
{
    return allocateNoThrow(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept
{
    return allocateNoThrow(size);
}
void* operator new(std::size_t size, std::align_val_t a)
{
    return allocate(size, std::size_t(a));
}
void* operator new[](std::size_t size, std::align_val_t a)
{
    return allocate(size, std::size_t(a));
}
void* operator new(std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept
{
    return allocateNoThrow(size, std::size_t(a));
}
void* operator new[](std::size_t size, std::align_val_t a, const std::nothrow_t&) noexcept
{
    return allocateNoThrow(size, std::size_t(a));
}
void operator delete(void* p) noexcept
{
    std::free(p);
}
void operator delete[](void* p) noexcept
{
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept
{
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept
{
    std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept
{
    std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept
{
    std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept
{
    std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept
{
    std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept
{
    std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept
{
    std::free(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept
{
    std::free(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept
{
    std::free(p);
}

namespace {

std::string& tempPath()
{
    static std::string path;
    return path;
}

void removeTemp()
{
    std::remove(tempPath().c_str());
}

// Valid grids whose meshing cost grows with their size (active tiles are voxelized; every slice of
// the active bounding box is sampled) would make most executions slow and some exceed the
// fuzzer's memory limit: a few mutated tile flags suffice. Those limits are pinned by
// tests/test_regressions.cpp; here such files are skipped, measured with OpenVDB itself before
// pipetile reads them. Damaged files always go on to pipetile.
constexpr openvdb::Index64 kMaxActiveVoxels = openvdb::Index64(1) << 20;
constexpr std::int64_t kMaxSide = 1024;

bool affordable(const openvdb::GridBase::Ptr& base)
{
    const openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) return true;
    if (grid->tree().activeVoxelCount() > kMaxActiveVoxels) return false;
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    if (box.empty()) return true;
    for (int axis = 0; axis < 3; ++axis)
        if (std::int64_t(box.max()[axis]) - box.min()[axis] + 1 > kMaxSide) return false;
    return true;
}

bool affordable(const std::string& path)
{
    // As readVolume reads: every grid through a stream that stops at the end of the file, or, if
    // another grid's type is unknown, grid by grid through io::File (a damaged other grid must
    // not hide a large one).
    try {
        std::ifstream in(path, std::ios::binary);
        in.exceptions(std::ios::failbit | std::ios::badbit | std::ios::eofbit);
        openvdb::io::Stream stream(in, /*delayLoad=*/false);
        for (const openvdb::GridBase::Ptr& grid : *stream.getGrids())
            if (!affordable(grid)) return false;
        return true;
    } catch (const openvdb::LookupError&) {
    } catch (const std::exception&) {
        return true;
    }
    try {
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/false);
        const openvdb::GridPtrVecPtr descriptions = file.readAllGridMetadata();
        for (const openvdb::GridBase::Ptr& description : *descriptions) {
            if (description->valueType() != "float") continue;
            try {
                if (!affordable(file.readGrid(description->getName()))) return false;
            } catch (const std::exception&) {
            }
        }
    } catch (const std::exception&) {
    }
    return true;
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    openvdb::initialize();
    // One file per process (libFuzzer's -jobs and -fork run several), rewritten for each input.
    tempPath() = (std::filesystem::temp_directory_path() / ("pipetile_fuzz_vdb_" + std::to_string(::getpid()) + ".vdb"))
                     .string();
    std::atexit(removeTemp);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    {
        std::ofstream out(tempPath(), std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
        if (!out) std::abort(); // the harness itself failed, not pipetile
    }
    if (!affordable(tempPath())) return -1; // libFuzzer keeps rejected inputs out of the corpus
    try {
        const pipetile::Volume volume = pipetile::readVolume(tempPath());
        pipetile::MeshOptions options;
        options.levels = 2;
        options.baseRays = 4;
        options.threads = 1;
        const pipetile::Reconstruction reconstruction(volume, options);
        const pipetile::LevelMesh mesh = reconstruction.buildLevel(1);
        if (mesh.rays != 8) __builtin_trap(); // level 1 of 4 base rays
    } catch (const pipetile::Error&) {
        // The documented answer to a file that cannot be meshed.
    }
    return 0;
}
