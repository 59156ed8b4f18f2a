// pipetile — mesh reading: .ply .obj .stl .off parsed exactly as written (why not through OpenMesh:
// include/pipetile/detail/mesh_read.h). Each format's parser fills a RawMesh, as the file states
// it; the checks every format shares (finite coordinates, indices in range) and the split of
// polygons into triangles come after, in one place.

#include <pipetile/detail/mesh_read.h>
#include <pipetile/error.h>
#include <pipetile/mesh_io.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <unordered_map>
#include <vector>

namespace pipetile {
namespace detail {

namespace {

constexpr std::uint64_t kMaxVertices = std::numeric_limits<std::uint32_t>::max(); // Triangle holds uint32 ids

// A mesh as its file states it, before the checks every format shares.
struct RawMesh {
    std::vector<glm::dvec3> vertices;
    std::vector<std::int64_t> corners;    // vertex indices of every face, face after face, as written
    std::vector<std::size_t> faceEnds;    // one past the last corner of each face
    std::vector<std::size_t> vertexLines; // text formats: the line of each vertex (empty for binary)
    std::vector<std::size_t> faceLines;   // text formats: the line of each face (empty for binary)
    std::int64_t firstIndex = 0;          // how the format numbers its first vertex: 1 in OBJ
};

// A value that cannot be read, thrown before the element it belongs to is known; the element's
// loop adds its name and number and throws Error.
struct Malformed {
    std::string what;
};

[[noreturn]] void fail(const std::string& file, const std::string& what)
{
    throw Error("'" + file + "': " + what);
}

// "face 12 (line 40)"; line 0 means a binary file, which has no lines.
std::string element(const std::string& kind, std::int64_t number, std::size_t line)
{
    std::string s = kind + " " + std::to_string(number);
    if (line > 0) s += " (line " + std::to_string(line) + ")";
    return s;
}

// A token from a file, shortened and with unprintable bytes replaced, so that a message stays one
// readable line whatever the file holds.
std::string quote(std::string_view token)
{
    std::string s = "'";
    for (std::size_t i = 0; i < token.size() && i < 40; ++i)
        s += std::isprint(static_cast<unsigned char>(token[i])) ? token[i] : '?';
    return s + (token.size() > 40 ? "...'" : "'");
}

std::string number(double x)
{
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%.17g", x);
    return buffer;
}

std::string point(const glm::dvec3& p)
{
    return "(" + number(p.x) + ", " + number(p.y) + ", " + number(p.z) + ")";
}

bool isSpace(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

// strtod reads what text formats write: "1e-3", "-0", "nan", "inf" (refused later, by name), and
// overflows to infinity (refused too) rather than failing.
std::optional<double> toDouble(std::string_view token)
{
    if (token.empty()) return std::nullopt;
    const std::string text(token);
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) return std::nullopt;
    return value;
}

std::optional<std::int64_t> toInteger(std::string_view token)
{
    if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
    std::int64_t value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (token.empty() || ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
    return value;
}

// The lines of a text, numbered from 1; a '\r' before the '\n' is dropped.
class LineReader {
public:
    explicit LineReader(std::string_view text) : mText(text) {}

    bool next(std::string_view& line)
    {
        if (mPos >= mText.size()) return false;
        std::size_t end = mText.find('\n', mPos);
        if (end == std::string_view::npos) end = mText.size();
        line = mText.substr(mPos, end - mPos);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        mPos = end + 1;
        ++mLine;
        return true;
    }
    std::size_t line() const { return mLine; } // of the line `next` returned last
    // Of the line after it: the end of the text after a last line with no newline.
    std::size_t offset() const { return std::min(mPos, mText.size()); }

private:
    std::string_view mText;
    std::size_t mPos = 0, mLine = 0;
};

// The whitespace-separated tokens of a line, without a comment that starts with `comment`.
void split(std::string_view line, std::vector<std::string_view>& tokens, char comment = '\0')
{
    if (comment) line = line.substr(0, line.find(comment));
    tokens.clear();
    std::size_t i = 0;
    while (true) {
        while (i < line.size() && isSpace(line[i])) ++i;
        if (i == line.size()) return;
        const std::size_t start = i;
        while (i < line.size() && !isSpace(line[i])) ++i;
        tokens.push_back(line.substr(start, i - start));
    }
}

// The whitespace-separated tokens of a text that is not line-based (PLY bodies, ASCII STL).
class TokenReader {
public:
    TokenReader(std::string_view text, std::size_t firstLine) : mText(text), mLine(firstLine) {}

    /// The next token, empty at the end of the text.
    std::string_view next()
    {
        while (mPos < mText.size() && isSpace(mText[mPos])) mLine += mText[mPos++] == '\n' ? 1 : 0;
        const std::size_t start = mPos;
        while (mPos < mText.size() && !isSpace(mText[mPos])) ++mPos;
        return mText.substr(start, mPos - start);
    }
    void skipLine()
    {
        while (mPos < mText.size() && mText[mPos] != '\n') ++mPos;
    }
    std::size_t line() const { return mLine; }

private:
    std::string_view mText;
    std::size_t mPos = 0, mLine;
};

// ---- PLY ---------------------------------------------------------------------------------------

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> plyType(std::string_view name)
{
    static const std::pair<const char*, PlyType> kNames[] = {
        {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
        {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
        {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
        {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
        {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
        {"float64", PlyType::Float64}};
    for (const auto& [text, type] : kNames)
        if (name == text) return type;
    return std::nullopt;
}

std::size_t plySize(PlyType type)
{
    switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8: return 1;
    case PlyType::Int16:
    case PlyType::UInt16: return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
    }
    return 8;
}

bool isInteger(PlyType type)
{
    return type != PlyType::Float32 && type != PlyType::Float64;
}

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;  // of the value, or of a list's items
    std::optional<PlyType> countType; // set for a list: the type of its length
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

enum class PlyEncoding { Ascii, LittleEndian, BigEndian };

struct PlyHeader {
    PlyEncoding encoding = PlyEncoding::Ascii;
    std::vector<PlyElement> elements;
    std::size_t bodyOffset = 0; // the byte after "end_header\n"
    std::size_t bodyLine = 0;   // the line that starts there
};

PlyProperty parsePlyProperty(const std::vector<std::string_view>& t, const std::string& file, const std::string& at)
{
    if (t.size() == 3 && plyType(t[1])) return {std::string(t[2]), *plyType(t[1]), std::nullopt};
    if (t.size() == 5 && t[1] == "list" && plyType(t[2]) && plyType(t[3])) {
        if (!isInteger(*plyType(t[2])))
            fail(file, at + ": the length of list " + quote(t[4]) + " must have an integer type");
        return {std::string(t[4]), *plyType(t[3]), plyType(t[2])};
    }
    fail(file, at + ": cannot read this property; expected 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
}

PlyHeader parsePlyHeader(std::string_view bytes, const std::string& file)
{
    LineReader lines(bytes);
    std::string_view line;
    if (!lines.next(line) || line != "ply") fail(file, "not a PLY file: it does not start with the line 'ply'");
    PlyHeader header;
    bool hasFormat = false;
    std::vector<std::string_view> t;
    while (lines.next(line)) {
        split(line, t);
        const std::string at = "line " + std::to_string(lines.line());
        if (t.empty() || t[0] == "comment" || t[0] == "obj_info") continue;
        if (t[0] == "end_header") {
            if (!hasFormat) fail(file, "the PLY header has no 'format' line");
            header.bodyOffset = lines.offset();
            header.bodyLine = lines.line() + 1;
            return header;
        }
        if (t[0] == "format" && t.size() == 3) {
            hasFormat = true;
            if (t[1] == "ascii")
                header.encoding = PlyEncoding::Ascii;
            else if (t[1] == "binary_little_endian")
                header.encoding = PlyEncoding::LittleEndian;
            else if (t[1] == "binary_big_endian")
                header.encoding = PlyEncoding::BigEndian;
            else
                fail(file, at + ": unknown PLY format " + quote(t[1]));
        } else if (t[0] == "element" && t.size() == 3) {
            const std::optional<std::int64_t> count = toInteger(t[2]);
            if (!count || *count < 0) fail(file, at + ": element " + quote(t[1]) + " has the count " + quote(t[2]));
            for (const PlyElement& e : header.elements)
                if (e.name == t[1]) fail(file, at + ": a second element " + quote(t[1]));
            header.elements.push_back({std::string(t[1]), static_cast<std::uint64_t>(*count), {}});
        } else if (t[0] == "property") {
            if (header.elements.empty()) fail(file, at + ": a property before any element");
            header.elements.back().properties.push_back(parsePlyProperty(t, file, at));
        } else {
            fail(file, at + ": cannot read this PLY header line, which starts with " + quote(t[0]));
        }
    }
    fail(file, "the PLY header has no 'end_header' line; the file is truncated or not a PLY file");
}

template <typename T>
T loadBinary(const char* p, bool bigEndian)
{
    unsigned char b[sizeof(T)];
    std::memcpy(b, p, sizeof(T));
    constexpr bool hostBigEndian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;
    if (bigEndian != hostBigEndian) std::reverse(b, b + sizeof(T));
    T value;
    std::memcpy(&value, b, sizeof(T));
    return value;
}

// The values of a PLY body, one after the other, in text or binary; throws Malformed.
class PlyBody {
public:
    PlyBody(std::string_view body, PlyEncoding encoding, std::size_t firstLine)
        : mData(body),
          mEncoding(encoding),
          mTokens(body, firstLine)
    {
    }

    double real(PlyType type)
    {
        if (text()) {
            const std::string_view token = nextToken();
            const std::optional<double> value = toDouble(token);
            if (!value) throw Malformed{quote(token) + " is not a number"};
            return *value;
        }
        return isInteger(type) ? static_cast<double>(integer(type)) : binary(type);
    }

    std::int64_t integer(PlyType type)
    {
        if (text()) {
            const std::string_view token = nextToken();
            const std::optional<std::int64_t> value = toInteger(token);
            if (!value) throw Malformed{quote(token) + " is not an integer"};
            return *value;
        }
        return static_cast<std::int64_t>(binary(type));
    }

    void skip(const PlyProperty& property)
    {
        std::int64_t items = 1;
        if (property.countType) {
            items = integer(*property.countType);
            if (items < 0) throw Malformed{"a list has the length " + std::to_string(items)};
        }
        if (text()) {
            for (std::int64_t k = 0; k < items; ++k) nextToken();
        } else {
            requireItems(items, property.type);
            mPos += static_cast<std::size_t>(items) * plySize(property.type);
        }
    }

    /// Throws unless a binary body holds `items` more values of `type` (a text body is checked value by value).
    void requireItems(std::int64_t items, PlyType type) const
    {
        if (!text() && static_cast<std::uint64_t>(items) > (mData.size() - mPos) / plySize(type))
            throw Malformed{items == 1 ? "the file ends here; it is truncated"
                                       : "it lists " + std::to_string(items) +
                                             " values, more than the rest of the file holds; the file is truncated"};
    }

    bool text() const { return mEncoding == PlyEncoding::Ascii; }
    std::size_t line() const { return text() ? mTokens.line() : 0; }
    std::size_t size() const { return mData.size(); }

private:
    std::string_view nextToken()
    {
        const std::string_view token = mTokens.next();
        if (token.empty()) throw Malformed{"the file ends here; it is truncated"};
        return token;
    }

    double binary(PlyType type)
    {
        const std::size_t n = plySize(type);
        if (mData.size() - mPos < n) throw Malformed{"the file ends here; it is truncated"};
        const char* p = mData.data() + mPos;
        mPos += n;
        const bool big = mEncoding == PlyEncoding::BigEndian;
        switch (type) {
        case PlyType::Int8: return static_cast<std::int8_t>(*p);
        case PlyType::UInt8: return static_cast<std::uint8_t>(*p);
        case PlyType::Int16: return loadBinary<std::int16_t>(p, big);
        case PlyType::UInt16: return loadBinary<std::uint16_t>(p, big);
        case PlyType::Int32: return loadBinary<std::int32_t>(p, big);
        case PlyType::UInt32: return loadBinary<std::uint32_t>(p, big);
        case PlyType::Float32: return loadBinary<float>(p, big);
        case PlyType::Float64: return loadBinary<double>(p, big);
        }
        return 0.0;
    }

    std::string_view mData;
    std::size_t mPos = 0;
    PlyEncoding mEncoding;
    TokenReader mTokens;
};

// Where a named property sits in an element; -1 if it has none.
int propertyIndex(const PlyElement& e, std::initializer_list<const char*> names)
{
    for (std::size_t k = 0; k < e.properties.size(); ++k)
        for (const char* n : names)
            if (e.properties[k].name == n) return static_cast<int>(k);
    return -1;
}

void readPlyVertices(PlyBody& body, const PlyElement& e, RawMesh& mesh, const std::string& file)
{
    const std::array<int, 3> xyz = {propertyIndex(e, {"x"}), propertyIndex(e, {"y"}), propertyIndex(e, {"z"})};
    for (int axis = 0; axis < 3; ++axis) {
        const char* name = axis == 0 ? "x" : axis == 1 ? "y" : "z";
        if (xyz[axis] < 0) fail(file, "the PLY element 'vertex' has no property '" + std::string(name) + "'");
        if (e.properties[xyz[axis]].countType)
            fail(file, "the PLY vertex property '" + std::string(name) + "' is a list");
    }
    if (e.count > kMaxVertices) fail(file, std::to_string(e.count) + " vertices, more than pipetile can index");
    mesh.vertices.reserve(std::min<std::uint64_t>(e.count, body.size() / 3)); // each takes 3 bytes at least
    std::uint64_t i = 0;
    try {
        for (; i < e.count; ++i) {
            glm::dvec3 p(0.0);
            for (std::size_t k = 0; k < e.properties.size(); ++k) {
                const int axis = static_cast<int>(std::find(xyz.begin(), xyz.end(), static_cast<int>(k)) - xyz.begin());
                if (axis < 3)
                    p[axis] = body.real(e.properties[k].type);
                else
                    body.skip(e.properties[k]);
            }
            mesh.vertices.push_back(p);
            if (body.text()) mesh.vertexLines.push_back(body.line());
        }
    } catch (const Malformed& m) {
        fail(file, element("vertex", static_cast<std::int64_t>(i), body.line()) + ": " + m.what);
    }
}

void readPlyFaces(PlyBody& body, const PlyElement& e, RawMesh& mesh, const std::string& file)
{
    const int indices = propertyIndex(e, {"vertex_indices", "vertex_index"});
    if (indices < 0) fail(file, "the PLY element 'face' has no list 'vertex_indices'");
    const PlyProperty& list = e.properties[indices];
    if (!list.countType || !isInteger(list.type))
        fail(file, "the PLY face property " + quote(list.name) + " must be a list of integers");
    std::uint64_t f = 0;
    try {
        for (; f < e.count; ++f) {
            for (std::size_t k = 0; k < e.properties.size(); ++k) {
                if (static_cast<int>(k) != indices) {
                    body.skip(e.properties[k]);
                    continue;
                }
                const std::int64_t n = body.integer(*list.countType);
                if (n < 3) throw Malformed{"it lists " + std::to_string(n) + " vertices; a face needs at least 3"};
                body.requireItems(n, list.type);
                for (std::int64_t j = 0; j < n; ++j) mesh.corners.push_back(body.integer(list.type));
            }
            mesh.faceEnds.push_back(mesh.corners.size());
            if (body.text()) mesh.faceLines.push_back(body.line());
        }
    } catch (const Malformed& m) {
        fail(file, element("face", static_cast<std::int64_t>(f), body.line()) + ": " + m.what);
    }
}

void skipPlyElement(PlyBody& body, const PlyElement& e, const std::string& file)
{
    if (e.properties.empty()) return; // nothing to read, however many there are
    std::uint64_t i = 0;
    try {
        // Every instance takes a byte or a token at least: a count past the end fails there.
        for (; i < e.count; ++i)
            for (const PlyProperty& p : e.properties) body.skip(p);
    } catch (const Malformed& m) {
        fail(file, element("element " + quote(e.name), static_cast<std::int64_t>(i), body.line()) + ": " + m.what);
    }
}

RawMesh parsePly(std::string_view bytes, const std::string& file)
{
    const PlyHeader header = parsePlyHeader(bytes, file);
    PlyBody body(bytes.substr(header.bodyOffset), header.encoding, header.bodyLine);
    RawMesh mesh;
    for (const PlyElement& e : header.elements) {
        if (e.name == "vertex")
            readPlyVertices(body, e, mesh, file);
        else if (e.name == "face")
            readPlyFaces(body, e, mesh, file);
        else
            skipPlyElement(body, e, file);
    }
    return mesh;
}

// ---- OBJ ---------------------------------------------------------------------------------------

// The vertex a face corner ("7", "7/2", "7//3", "-1/5") refers to, 1-based; a negative index
// counts back from the last vertex before the face.
std::int64_t objCorner(std::string_view corner, std::size_t verticesBefore, const std::string& file,
                       const std::string& at)
{
    const std::string_view ref = corner.substr(0, corner.find('/'));
    const std::optional<std::int64_t> index = toInteger(ref);
    if (!index) fail(file, at + ": " + quote(corner) + " is not a vertex index");
    if (*index == 0) fail(file, at + ": it refers to vertex 0, but OBJ numbers vertices from 1");
    if (*index > 0) return *index; // may refer to a vertex further down; checked once all are read
    if (*index < -static_cast<std::int64_t>(verticesBefore))
        fail(file, at + ": it refers to vertex " + std::to_string(*index) + ", but only " +
                       std::to_string(verticesBefore) + " vertices precede it");
    return static_cast<std::int64_t>(verticesBefore) + *index + 1;
}

RawMesh parseObj(std::string_view bytes, const std::string& file)
{
    RawMesh mesh;
    mesh.firstIndex = 1;
    LineReader lines(bytes);
    std::string_view line;
    std::vector<std::string_view> t;
    while (lines.next(line)) {
        split(line, t, '#');
        if (t.empty()) continue;
        if (t[0] == "v") {
            const std::string at = element("vertex", static_cast<std::int64_t>(mesh.vertices.size()) + 1, lines.line());
            if (t.size() < 4) fail(file, at + ": it has fewer than 3 coordinates");
            glm::dvec3 p;
            for (int axis = 0; axis < 3; ++axis) {
                const std::optional<double> value = toDouble(t[1 + axis]);
                if (!value) fail(file, at + ": " + quote(t[1 + axis]) + " is not a number");
                p[axis] = *value;
            }
            if (mesh.vertices.size() == kMaxVertices) fail(file, "more vertices than pipetile can index");
            mesh.vertices.push_back(p);
            mesh.vertexLines.push_back(lines.line());
        } else if (t[0] == "f") {
            const std::string at = element("face", static_cast<std::int64_t>(mesh.faceEnds.size()) + 1, lines.line());
            if (t.size() < 4)
                fail(file, at + ": it lists " + std::to_string(t.size() - 1) + " vertices; a face needs at least 3");
            for (std::size_t k = 1; k < t.size(); ++k)
                mesh.corners.push_back(objCorner(t[k], mesh.vertices.size(), file, at));
            mesh.faceEnds.push_back(mesh.corners.size());
            mesh.faceLines.push_back(lines.line());
        }
        // Everything else (vt, vn, g, o, s, usemtl, mtllib, l, p, ...) does not change the surface.
    }
    return mesh;
}

// ---- OFF ---------------------------------------------------------------------------------------

// The tokens of the next line that has any, without comments; false at the end of the file.
bool nextTokens(LineReader& lines, std::vector<std::string_view>& t)
{
    std::string_view line;
    while (lines.next(line)) {
        split(line, t, '#');
        if (!t.empty()) return true;
    }
    return false;
}

// The keyword [ST][C][N][4][n]OFF[ BINARY]: only 3D text OFF is read.
void checkOffKeyword(const std::vector<std::string_view>& t, const std::string& file)
{
    std::string_view k = t[0];
    for (const char* prefix : {"ST", "C", "N"})
        if (k.substr(0, std::strlen(prefix)) == prefix) k.remove_prefix(std::strlen(prefix));
    if (k == "4OFF" || k == "nOFF" || k == "4nOFF")
        fail(file, "OFF with other than 3 coordinates per vertex is not supported");
    if (k != "OFF") fail(file, "not an OFF file: it does not start with OFF");
    if (t.size() > 1 && t[1] == "BINARY")
        fail(file, "binary OFF is not supported; save the mesh as text OFF, PLY or STL");
}

RawMesh parseOff(std::string_view bytes, const std::string& file)
{
    LineReader lines(bytes);
    std::vector<std::string_view> t;
    if (!nextTokens(lines, t)) fail(file, "the file is empty");
    checkOffKeyword(t, file);
    // The counts "vertices faces edges" follow the keyword, on its line or the next.
    if (t.size() > 1)
        t.erase(t.begin());
    else if (!nextTokens(lines, t))
        fail(file, "the file ends before the vertex and face counts");
    const std::optional<std::int64_t> vertexCount = toInteger(t[0]);
    const std::optional<std::int64_t> faceCount = t.size() > 1 ? toInteger(t[1]) : std::nullopt;
    if (!vertexCount || !faceCount || *vertexCount < 0 || *faceCount < 0)
        fail(file, "line " + std::to_string(lines.line()) + ": expected the vertex and face counts");
    if (static_cast<std::uint64_t>(*vertexCount) > kMaxVertices)
        fail(file, std::to_string(*vertexCount) + " vertices, more than pipetile can index");

    RawMesh mesh;
    mesh.vertices.reserve(std::min<std::uint64_t>(*vertexCount, bytes.size() / 6)); // "0 0 0\n" at least
    for (std::int64_t i = 0; i < *vertexCount; ++i) {
        if (!nextTokens(lines, t))
            fail(file, "the file ends after " + std::to_string(i) + " of " + std::to_string(*vertexCount) +
                           " vertices; it is truncated");
        const std::string at = element("vertex", i, lines.line());
        if (t.size() < 3) fail(file, at + ": it has fewer than 3 coordinates");
        glm::dvec3 p;
        for (int axis = 0; axis < 3; ++axis) {
            const std::optional<double> value = toDouble(t[axis]);
            if (!value) fail(file, at + ": " + quote(t[axis]) + " is not a number");
            p[axis] = *value;
        }
        mesh.vertices.push_back(p);
        mesh.vertexLines.push_back(lines.line());
    }
    for (std::int64_t f = 0; f < *faceCount; ++f) {
        if (!nextTokens(lines, t))
            fail(file, "the file ends after " + std::to_string(f) + " of " + std::to_string(*faceCount) +
                           " faces; it is truncated");
        const std::string at = element("face", f, lines.line());
        const std::optional<std::int64_t> n = toInteger(t[0]);
        if (!n) fail(file, at + ": " + quote(t[0]) + " is not a vertex count");
        if (*n < 3) fail(file, at + ": it lists " + std::to_string(*n) + " vertices; a face needs at least 3");
        if (static_cast<std::uint64_t>(*n) > t.size() - 1)
            fail(file, at + ": it lists " + std::to_string(*n) + " vertices but gives " + std::to_string(t.size() - 1) +
                           " indices");
        for (std::int64_t k = 1; k <= *n; ++k) {
            const std::optional<std::int64_t> index = toInteger(t[k]);
            if (!index) fail(file, at + ": " + quote(t[k]) + " is not a vertex index");
            mesh.corners.push_back(*index);
        }
        // Whatever follows the indices is the face's colour.
        mesh.faceEnds.push_back(mesh.corners.size());
        mesh.faceLines.push_back(lines.line());
    }
    return mesh;
}

// ---- STL ---------------------------------------------------------------------------------------

// Each facet's three corners, in file order, and for ASCII the line of each facet.
struct StlSoup {
    std::vector<glm::dvec3> corners;
    std::vector<std::size_t> facetLines;
};

constexpr std::size_t kStlHeader = 84, kStlFacet = 50; // 80-byte header + uint32 count; 12 floats + uint16

std::uint64_t stlBinaryCount(std::string_view bytes)
{
    return loadBinary<std::uint32_t>(bytes.data() + 80, false);
}

bool isBinaryStl(std::string_view bytes)
{
    // The size is the sure sign: many binary files begin with "solid" too.
    return bytes.size() >= kStlHeader && kStlHeader + kStlFacet * stlBinaryCount(bytes) == bytes.size();
}

StlSoup readBinaryStl(std::string_view bytes)
{
    StlSoup soup;
    const std::uint64_t count = stlBinaryCount(bytes);
    soup.corners.reserve(3 * count);
    for (std::uint64_t f = 0; f < count; ++f) {
        const char* facet = bytes.data() + kStlHeader + kStlFacet * f;
        for (int c = 1; c <= 3; ++c) { // after the normal
            const char* p = facet + 12 * c;
            soup.corners.push_back(glm::dvec3(loadBinary<float>(p, false), loadBinary<float>(p + 4, false),
                                              loadBinary<float>(p + 8, false)));
        }
    }
    return soup;
}

StlSoup readAsciiStl(std::string_view bytes, const std::string& file)
{
    StlSoup soup;
    TokenReader tokens(bytes, 1);
    bool inFacet = false, ended = true; // ended: no facet since the last "endsolid"
    std::size_t cornersInFacet = 0;
    auto next = [&]() {
        const std::string_view token = tokens.next();
        if (token.empty()) fail(file, "the file ends inside its last facet; it is truncated");
        return token;
    };
    auto expect = [&](std::string_view word) {
        const std::string_view token = next();
        if (token != word)
            fail(file, "line " + std::to_string(tokens.line()) + ": expected '" + std::string(word) + "', found " +
                           quote(token));
    };
    for (std::string_view token = tokens.next(); !token.empty(); token = tokens.next()) {
        const std::string at = "line " + std::to_string(tokens.line());
        if ((token == "solid" || token == "endsolid") && !inFacet) {
            tokens.skipLine(); // the solid's name
            ended = token == "endsolid";
        } else if (token == "facet" && !inFacet) {
            expect("normal");
            for (int k = 0; k < 3; ++k) next(); // the normal follows from the corners
            inFacet = true;
            ended = false;
            cornersInFacet = 0;
            soup.facetLines.push_back(tokens.line());
        } else if (token == "outer" && inFacet) {
            expect("loop");
        } else if (token == "vertex" && inFacet) {
            glm::dvec3 p;
            for (int axis = 0; axis < 3; ++axis) {
                const std::string_view value = next();
                const std::optional<double> x = toDouble(value);
                if (!x) fail(file, at + ": " + quote(value) + " is not a number");
                p[axis] = *x;
            }
            soup.corners.push_back(p);
            ++cornersInFacet;
        } else if (token == "endloop" && inFacet) {
        } else if (token == "endfacet" && inFacet) {
            if (cornersInFacet != 3)
                fail(file,
                     element("facet", static_cast<std::int64_t>(soup.facetLines.size()) - 1, soup.facetLines.back()) +
                         ": it has " + std::to_string(cornersInFacet) + " corners; an STL facet has 3");
            inFacet = false;
        } else {
            fail(file, at + ": unexpected " + quote(token));
        }
    }
    if (inFacet) fail(file, "the file ends inside its last facet; it is truncated");
    if (!ended) fail(file, "the file ends without 'endsolid'; it is truncated");
    return soup;
}

// One vertex per distinct corner position, in order of first appearance. A NaN corner is refused
// here, by facet, since it could never be equal to another.
RawMesh weldStl(const StlSoup& soup, const std::string& file)
{
    struct KeyHash {
        std::size_t operator()(const std::array<std::uint64_t, 3>& k) const
        {
            return static_cast<std::size_t>((k[0] * 0x9E3779B97F4A7C15ull) ^ (k[1] * 0xC2B2AE3D27D4EB4Full) ^ k[2]);
        }
    };
    std::unordered_map<std::array<std::uint64_t, 3>, std::int64_t, KeyHash> ids;
    RawMesh mesh;
    mesh.corners.reserve(soup.corners.size());
    for (std::size_t c = 0; c < soup.corners.size(); ++c) {
        const glm::dvec3& p = soup.corners[c];
        const std::size_t facet = c / 3;
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            fail(file, element("facet", static_cast<std::int64_t>(facet),
                               facet < soup.facetLines.size() ? soup.facetLines[facet] : 0) +
                           " has the corner " + point(p) +
                           ": a coordinate is not a finite number; the file is corrupt");
        std::array<std::uint64_t, 3> key;
        for (int axis = 0; axis < 3; ++axis) {
            const double x = p[axis] + 0.0; // -0 + 0 is +0: one key for both zeros
            std::memcpy(&key[axis], &x, sizeof x);
        }
        const auto [it, added] = ids.emplace(key, static_cast<std::int64_t>(mesh.vertices.size()));
        if (added) mesh.vertices.push_back(p);
        mesh.corners.push_back(it->second);
        if (c % 3 == 2) mesh.faceEnds.push_back(mesh.corners.size());
    }
    mesh.faceLines = soup.facetLines;
    return mesh;
}

RawMesh parseStl(std::string_view bytes, const std::string& file)
{
    if (isBinaryStl(bytes)) return weldStl(readBinaryStl(bytes), file);
    const std::size_t start = std::find_if_not(bytes.begin(), bytes.end(), isSpace) - bytes.begin();
    if (bytes.substr(start, 5) == "solid") return weldStl(readAsciiStl(bytes, file), file);
    if (bytes.size() >= kStlHeader)
        fail(file, "a binary STL of " + std::to_string(stlBinaryCount(bytes)) + " triangles has " +
                       std::to_string(kStlHeader + kStlFacet * stlBinaryCount(bytes)) + " bytes, but the file has " +
                       std::to_string(bytes.size()) + "; it is truncated or not an STL file");
    fail(file, "not an STL file: too short for a binary STL, and it does not start with 'solid'");
}

// ---- What every format shares ------------------------------------------------------------------

void checkCoordinates(const RawMesh& mesh, const std::string& file)
{
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
        const glm::dvec3& p = mesh.vertices[i];
        if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) continue;
        fail(file, element("vertex", static_cast<std::int64_t>(i) + mesh.firstIndex,
                           i < mesh.vertexLines.size() ? mesh.vertexLines[i] : 0) +
                       " is " + point(p) + ": a coordinate is not a finite number; the file is corrupt");
    }
}

void checkIndices(const RawMesh& mesh, const std::string& file)
{
    const auto n = static_cast<std::int64_t>(mesh.vertices.size());
    std::size_t begin = 0;
    for (std::size_t f = 0; f < mesh.faceEnds.size(); begin = mesh.faceEnds[f++]) {
        for (std::size_t c = begin; c < mesh.faceEnds[f]; ++c) {
            const std::int64_t index = mesh.corners[c];
            if (index >= mesh.firstIndex && index - mesh.firstIndex < n) continue;
            const std::string has = n == 0 ? "the file has no vertices"
                                           : "the file has " + std::to_string(n) + " vertices, numbered " +
                                                 std::to_string(mesh.firstIndex) + " to " +
                                                 std::to_string(n - 1 + mesh.firstIndex);
            fail(file, element("face", static_cast<std::int64_t>(f) + mesh.firstIndex,
                               f < mesh.faceLines.size() ? mesh.faceLines[f] : 0) +
                           " refers to vertex " + std::to_string(index) + ", but " + has + "; the file is corrupt");
        }
    }
}

// Polygons split into fans, indices from 0.
TriangleMesh triangulate(RawMesh&& raw)
{
    TriangleMesh mesh;
    mesh.vertices = std::move(raw.vertices);
    mesh.triangles.reserve(raw.corners.size() - 2 * raw.faceEnds.size());
    auto id = [&](std::size_t c) { return static_cast<std::uint32_t>(raw.corners[c] - raw.firstIndex); };
    std::size_t begin = 0;
    for (const std::size_t end : raw.faceEnds) {
        for (std::size_t c = begin + 1; c + 1 < end; ++c) mesh.triangles.push_back({id(begin), id(c), id(c + 1)});
        begin = end;
    }
    return mesh;
}

RawMesh parseRaw(std::string_view bytes, MeshFormat format, const std::string& file)
{
    switch (format) {
    case MeshFormat::Ply: return parsePly(bytes, file);
    case MeshFormat::Obj: return parseObj(bytes, file);
    case MeshFormat::Stl: return parseStl(bytes, file);
    case MeshFormat::Off: return parseOff(bytes, file);
    }
    fail(file, "unknown mesh format");
}

} // namespace

std::optional<MeshFormat> meshFormatOf(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".ply") return MeshFormat::Ply;
    if (ext == ".obj") return MeshFormat::Obj;
    if (ext == ".stl") return MeshFormat::Stl;
    if (ext == ".off") return MeshFormat::Off;
    return std::nullopt;
}

TriangleMesh parseMesh(std::string_view bytes, MeshFormat format, const std::string& name)
{
    RawMesh raw = parseRaw(bytes, format, name);
    checkCoordinates(raw, name);
    checkIndices(raw, name);
    return triangulate(std::move(raw));
}

} // namespace detail

TriangleMesh readMesh(const std::string& path)
{
    std::error_code ec;
    const std::filesystem::file_status status = std::filesystem::status(path, ec);
    if (!std::filesystem::exists(status)) throw Error("'" + path + "': no such mesh file; check the path");
    if (!std::filesystem::is_regular_file(status))
        throw Error("'" + path + "': not a regular file (a folder, pipe or device); save the mesh to a file first");
    const std::optional<detail::MeshFormat> format = detail::meshFormatOf(path);
    if (!format)
        throw Error("'" + path + "': unknown mesh format '" + std::filesystem::path(path).extension().string() +
                    "'; use .ply .obj .stl .off");
    const std::uintmax_t size = std::filesystem::file_size(path, ec);
    std::ifstream in(path, std::ios::binary);
    if (ec || !in)
        throw Error("'" + path + "': cannot be opened (" + std::strerror(errno) + "); check its permissions");
    std::string bytes(size, '\0');
    if (!in.read(bytes.data(), static_cast<std::streamsize>(size)))
        throw Error("'" + path + "': could not be read to its end; check the file and the disk");
    return detail::parseMesh(bytes, *format, path);
}

} // namespace pipetile
