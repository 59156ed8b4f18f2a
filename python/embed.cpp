// pipetile — the Python module's work, in C++ free of pybind11 and OpenVDB.

#include "embed.h"

#include "frame.h"
#include "report.h"

#include <pipetile/validate.h>

#include <chrono>

namespace pipetile::python {

MeshedLevels meshLevels(const Volume& volume, const MeshOptions& options)
{
    const auto start = std::chrono::steady_clock::now();
    const Reconstruction reconstruction(volume, options);
    Refinement refinement(reconstruction);
    std::vector<LevelMesh> levels{refinement.mesh()};
    while (refinement.canRefine()) levels.push_back(refinement.refine());

    nlohmann::json report = tools::meshReport(volume, reconstruction);
    for (const LevelMesh& level : levels) report["levels"].push_back(tools::levelReport(level, /*topology=*/true));
    MeshedLevels result{nestLevels(levels), {}};
    // Meshing and the levels' topology; unlike the CLI's, reading the volume and writing files are not in it.
    report["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.report = tools::reportText(report);
    return result;
}

MeshedFiles meshFiles(const std::string& input, const std::string& output, const std::string& report,
                      const VolumeOptions& volume, const MeshOptions& options)
{
    MeshedFiles result;
    tools::FrameJob job;
    job.input = input;
    job.output = output;
    job.report = report;
    job.owner = "pipetile Python module";
    job.options = options;
    job.volume = volume;
    job.notify = [&](const char* kind, const std::string& text) {
        result.notes.push_back(std::string(kind) + ": " + text);
    };
    result.report = tools::reportText(tools::meshFrame(job));
    return result;
}

std::string validateMesh(const Volume& volume, const TriangleMesh& mesh, int threads)
{
    const Validator validator(volume, {1.0, threads});
    return tools::reportText(tools::validationReport(validator.validate(mesh)));
}

} // namespace pipetile::python
