// pipetile — one volume meshed into its level files and report, as one transaction: the work of
// `pipetile mesh` on one input, shared by the CLI (one file, or each frame of a sequence) and the
// Python module (pipetile.dask), so that both write the same bytes.
#pragma once

#include <pipetile/gltf.h>
#include <pipetile/multires.h>
#include <pipetile/output_set.h>
#include <pipetile/volume.h>

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pipetile::tools {

/// name_L<k>.ext next to the path the user gave.
std::string levelPath(const std::string& output, int level);

/// Level files an earlier run with more levels left beside `output`: name_L<k>.ext with k >= `levels`,
/// exactly as levelPath spells them (same folder, stem and extension, k in decimal without
/// leading zeros), regular files only. Other formats (name_L<k>.obj beside a .ply set), a .glb,
/// and any other name are not the set's and stay. None for a .glb output.
std::vector<std::string> staleLevels(const std::string& output, int levels);

/// @throw Error naming `path` if its folder does not exist; `what` names the file ("meshes").
void checkWritableTarget(const std::string& path, const char* what);

/// Whether every output of a run exists: the `levels` level files of `output` (or the one .glb)
/// and the report (unless empty). A run's files are committed together, the report last, so a
/// stopped run left either all of its own or none (--skip-existing).
bool outputsExist(const std::string& output, const std::string& report, int levels);

/// A line for the user that is not an error: `kind` is "note" or "warning"; the CLI prints
/// "pipetile: <kind>: <text>" on stderr, the Python module collects them.
using Notify = std::function<void(const char* kind, const std::string& text)>;

struct NamedPath {
    std::string path;
    std::string what; // "input volume", "report", ...
};

/// Refuses, before any work, an output that is one of the inputs or another output: it would be
/// overwritten (a report over the volume it describes, a coloured mesh over the mesh it reads).
/// @throw UsageError naming both.
void refuseClobbering(const std::vector<NamedPath>& inputs, const std::vector<NamedPath>& outputs);

/// The run's outputs as one transaction, locked before any work: a concurrent run writing any of
/// them fails now, and is told `owner`. `obsolete` files go when it commits, and come back if it
/// fails. Temporaries a killed run left are removed, and a commit it left half done is finished,
/// with a note.
/// @throw Error as OutputSet.
std::unique_ptr<OutputSet> openOutputs(const std::vector<NamedPath>& outputs, const std::string& owner,
                                       const Notify& notify, const std::vector<std::string>& obsolete = {});

/// Notes on the isovalue that deserve a second look: the default fog isovalue left hot voxels
/// out, or so few voxels lie inside that the mesh can only be specks.
void noteIsovalue(const Volume& volume, const Notify& notify);

/// One input to mesh: what to read, what to write, and who hears about it.
struct FrameJob {
    std::string input;            // the .vdb file (empty with `read` set: a sample), for the clobbering check
    std::string output;           // mesh path; level k goes to levelPath(output, k)
    std::string report;           // JSON report path; empty: none
    std::string html;             // HTML report path; empty: none
    double metresPerUnit = 1.0;   // a .glb's scale: the grid's world unit in metres (glTF's unit)
    std::string owner;            // who writes (the command line), for a concurrent run's message
    MeshOptions options;          // checked by meshFrame
    VolumeOptions volume;         // grid and isovalue, for reading `input`
    std::function<Volume()> read; // empty: readVolume(input, volume); set: the volume
                                  // read elsewhere (a sample, or read ahead)
    Notify notify;                // notes and warnings; must be set
    std::function<void(int level, int levels)> levelDone; // progress after each level; may be empty
    /// Before the commit, with the report complete but for validation: prints, validates (adding
    /// to the report, and for a .glb or an HTML report each vertex's error, in the order of
    /// `nested`, to `glb`). `nested` is empty unless a .glb or an HTML report is written. May be empty.
    std::function<void(const Volume&, const Reconstruction&, const std::vector<LevelMesh>&, const NestedLevels& nested,
                       nlohmann::json& report, GlbOptions& glb)>
        beforeCommit;
    /// After the commit, the lock files gone, with the volume and the levels still alive: a
    /// program that is done may end here without tearing them down. May be empty.
    std::function<void()> committed;
};

/// Reads, meshes every level (level 0, then each refined from the one before) and writes the
/// levels and the report as one transaction: locked before reading, committed last.
/// Returns the report (with "file" per level and "seconds", the whole frame's time).
/// @throw UsageError for options out of range or an output that is the input; Error as
/// readVolume, Reconstruction and OutputSet (nothing is then written).
nlohmann::json meshFrame(const FrameJob& job);

} // namespace pipetile::tools
