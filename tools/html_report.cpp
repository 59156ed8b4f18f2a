// pipetile — the HTML report: the page template filled with the run's data and its levels' .glb.

#include "html_report.h"
#include "report.h"

#include <pipetile/error.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <sstream>

namespace pipetile::tools {

namespace {

std::string base64(const std::string& bytes)
{
    static const char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
        std::uint32_t group = 0;
        for (std::size_t k = 0; k < 3; ++k)
            group = group << 8 | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
        for (std::size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[group >> (18 - 6 * k) & 63] : '=';
    }
    return out;
}

// JSON inside a <script> element: "</" would end the element, so it is written "<\/" (same JSON).
std::string scriptSafeJson(const nlohmann::json& value)
{
    std::string text = reportText(value);
    for (std::size_t at = text.find("</"); at != std::string::npos; at = text.find("</", at + 3))
        text.insert(at + 1, "\\");
    return text;
}

} // namespace

void checkHtmlReportAvailable(const std::string& path)
{
    if (std::strlen(kReportPage) == 0)
        throw Error("--html '" + path +
                    "': this pipetile was built without the HTML report (npm was not found at build "
                    "time); install nodejs and npm, then rebuild");
}

TriangleMesh nestedMesh(const NestedLevels& nested, std::size_t level)
{
    TriangleMesh mesh;
    const auto end = nested.vertices.begin() + static_cast<std::ptrdiff_t>(nested.vertexCounts[level]);
    mesh.vertices.assign(nested.vertices.begin(), end);
    mesh.triangles = nested.triangles[level];
    return mesh;
}

void writeHtmlReport(OutputSet& outputs, const std::string& path, const HtmlReport& report, const NestedLevels& nested,
                     const GlbOptions& glb)
{
    checkHtmlReportAvailable(path);
    std::ostringstream glbBytes;
    writeGlb(glbBytes, nested, glb, path);
    const nlohmann::json data = {
        {"title", report.title},
        {"subtitle", report.subtitle},
        {"levels", report.levels},
        {"peers", report.peers},
        {"glb", {{"metres_per_unit", glb.metresPerUnit}, {"voxel_metres", report.voxel * glb.metresPerUnit}}}};
    const std::string page = kReportPage;
    const std::string marker = "<!--PIPETILE_DATA-->";
    const std::size_t at = page.find(marker);
    if (at == std::string::npos) throw Error("--html '" + path + "': the built-in page has no place for the data");
    outputs.write(path, [&](std::ostream& out) {
        out.write(page.data(), static_cast<std::streamsize>(at));
        out << "<script id=\"pipetile-data\" type=\"application/json\">" << scriptSafeJson(data) << "</script>\n"
            << "<script id=\"pipetile-glb\" type=\"application/octet-stream\">" << base64(glbBytes.str())
            << "</script>";
        out << page.substr(at + marker.size());
    });
}

} // namespace pipetile::tools
