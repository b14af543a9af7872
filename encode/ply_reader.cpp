// PLY (binary little-endian and ASCII) into an IndexedMesh: the header's elements and properties,
// their counts checked against the data's size before anything is allocated, then the data.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sstream>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/format_readers.h"

namespace isoslab::format {
namespace {

// A scalar's type in the data: a signed or unsigned integer or a float, and its size in bytes.
struct Scalar {
  enum Kind : std::uint8_t { kSigned, kUnsigned, kFloat } kind = kSigned;
  std::uint8_t size = 0;  // 0: unknown
};

struct Property {
  std::string name;
  std::string type;       // scalar type, or the item type of a list
  std::string countType;  // set for lists
  // Resolved once from the strings above, for the data: the types, where the value goes (x, y, z,
  // nx, ny, nz as 0 to 5; -1: nowhere) and whether a list holds a face's vertex indices.
  Scalar scalar, count;
  int role = -1;
  bool indices = false;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  bool ascii = false;
  std::vector<Element> elements;
};

Scalar scalarType(const std::string& t) {
  if (t == "char" || t == "int8") return {Scalar::kSigned, 1};
  if (t == "uchar" || t == "uint8") return {Scalar::kUnsigned, 1};
  if (t == "short" || t == "int16") return {Scalar::kSigned, 2};
  if (t == "ushort" || t == "uint16") return {Scalar::kUnsigned, 2};
  if (t == "int" || t == "int32") return {Scalar::kSigned, 4};
  if (t == "uint" || t == "uint32") return {Scalar::kUnsigned, 4};
  if (t == "float" || t == "float32") return {Scalar::kFloat, 4};
  if (t == "double" || t == "float64") return {Scalar::kFloat, 8};
  return {};
}

double decode(const char* p, Scalar t) {
  auto get = [p]<typename T>(T) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  };
  switch (t.size) {
    case 1:
      return t.kind == Scalar::kSigned ? get(std::int8_t{}) : get(std::uint8_t{});
    case 2:
      return t.kind == Scalar::kSigned ? get(std::int16_t{}) : get(std::uint16_t{});
    case 4:
      return t.kind == Scalar::kFloat    ? get(float{})
             : t.kind == Scalar::kSigned ? get(std::int32_t{})
                                         : get(std::uint32_t{});
    default:
      return get(double{});
  }
}

class Input {
 public:
  Input(const std::string& path, std::string data) : path_(path), data_(std::move(data)) {}
  const char* take(std::size_t n) {
    if (pos_ + n > data_.size()) throw Error(fmt::format("{}: the file is truncated", path_));
    const char* p = data_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::string line() {
    const std::size_t end = data_.find('\n', pos_);
    if (end == std::string::npos) throw Error(fmt::format("{}: the PLY header is not terminated", path_));
    std::string l = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    return l;
  }
  // ASCII data: the next word (a run of characters that are not white space; a NUL is one of
  // them), as a pointer into the data, which a NUL ends, and its length; null after the last word.
  const char* word(std::size_t& length) {
    const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; };
    while (pos_ < data_.size() && space(data_[pos_])) ++pos_;
    if (pos_ == data_.size()) return nullptr;
    const std::size_t start = pos_;
    while (pos_ < data_.size() && !space(data_[pos_])) ++pos_;
    length = pos_ - start;
    return data_.c_str() + start;
  }
  std::size_t remaining() const { return data_.size() - pos_; }

 private:
  std::string path_;
  std::string data_;
  std::size_t pos_ = 0;
};

Property parseProperty(std::istringstream& s, const std::string& element, const std::string& line,
                       const std::string& path) {
  Property p;
  std::string t;
  s >> t;
  if (t == "list") {
    s >> p.countType >> p.type >> p.name;
  } else {
    p.type = t;
    s >> p.name;
  }
  p.scalar = scalarType(p.type);
  if (!p.countType.empty()) p.count = scalarType(p.countType);
  if (p.scalar.size == 0 || (!p.countType.empty() && p.count.size == 0)) {
    throw Error(fmt::format("{}: unknown PLY property type in '{}'", path, line));
  }
  static const char* kNames[6] = {"x", "y", "z", "nx", "ny", "nz"};
  if (p.countType.empty()) {
    for (int k = 0; k < 6; ++k) p.role = p.name == kNames[k] ? k : p.role;
  } else {
    p.indices = element == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
  }
  return p;
}

// An element's count: a whole number written in decimal digits alone (no sign, point or exponent),
// at most 2^64 - 1; checkCounts() then holds it to the data's size. The istream extraction this
// replaces read "lots" as 0 (an empty mesh) and "-5" as 2^64 - 5.
std::uint64_t elementCount(const std::string& word, const std::string& line, int lineNumber, const std::string& path) {
  const auto where = fmt::format("{}: PLY header line {} '{}'", path, lineNumber,
                                 line.size() <= 80 ? line : line.substr(0, 77) + "...");
  if (word.empty()) throw Error(where + ": the element has no count");
  if (!std::all_of(word.begin(), word.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    throw Error(fmt::format("{}: the element count '{}' is not a whole number", where, word));
  }
  std::uint64_t count = 0;
  const auto [stop, error] = std::from_chars(word.data(), word.data() + word.size(), count);
  if (error != std::errc() || stop != word.data() + word.size()) {
    throw Error(fmt::format("{}: the element count {} is beyond 2^64 - 1", where, word));
  }
  return count;
}

Header parseHeader(Input& in, const std::string& path, MeshMetadata& meta) {
  if (in.line() != "ply") throw Error(fmt::format("{}: not a PLY file", path));
  std::string format;
  Header header;
  int lineNumber = 2;
  for (std::string l = in.line(); l != "end_header"; l = in.line(), ++lineNumber) {
    std::istringstream s(l);
    std::string word;
    s >> word;
    if (word == "format") {
      s >> format;
    } else if (word == "comment" || word == "obj_info") {
      const std::size_t text = l.find_first_not_of(' ', word.size());
      if (text != std::string::npos) parseMetadataLine(l.substr(text), meta);
    } else if (word == "element") {
      Element e;
      std::string count, extra;
      s >> e.name >> count;
      if (e.name.empty()) throw Error(fmt::format("{}: PLY header line {} '{}' names no element", path, lineNumber, l));
      e.count = elementCount(count, l, lineNumber, path);
      if (s >> extra) {
        throw Error(
            fmt::format("{}: PLY header line {} '{}': '{}' follows the element count", path, lineNumber, l, extra));
      }
      header.elements.push_back(e);
    } else if (word == "property") {
      if (header.elements.empty()) throw Error(fmt::format("{}: a PLY property precedes every element", path));
      header.elements.back().properties.push_back(parseProperty(s, header.elements.back().name, l, path));
    }
  }
  if (format != "binary_little_endian" && format != "ascii") {
    throw Error(fmt::format("{}: PLY format '{}' is not supported (binary_little_endian or ascii)", path, format));
  }
  header.ascii = format == "ascii";
  return header;
}

// Every element takes at least one byte per property (two in ASCII, with its separator), so the
// counts are checked against the data's size before anything is read or allocated.
void checkCounts(const Header& header, std::uint64_t have, const std::string& path) {
  std::uint64_t need = 0;
  for (const Element& e : header.elements) {
    if (e.count == 0) continue;
    if (e.properties.empty()) {
      throw Error(fmt::format("{}: PLY element '{}' claims {} items but has no properties", path, e.name, e.count));
    }
    std::uint64_t least = 0;
    for (const Property& p : e.properties)
      least += header.ascii ? 2 : (p.countType.empty() ? p.scalar.size : p.count.size);
    if (header.ascii) --least;
    if (e.count > (have - std::min(have, need)) / least) {
      throw Error(fmt::format("{}: PLY element '{}' claims {} items, more than its {} data bytes hold", path, e.name,
                              e.count, have));
    }
    need += e.count * least;
  }
}

// The data after the header, one scalar at a time, in the header's format.
class Body {
 public:
  Body(Input& in, bool ascii, const std::string& path)
      : in_(in), ascii_(ascii), path_(path), textSize_(ascii ? in.remaining() : 0) {}

  double scalar(Scalar type) {
    if (!ascii_) return decode(in_.take(type.size), type);
    // The next word, read whole as a number.
    std::size_t length = 0;
    const char* word = in_.word(length);
    if (word == nullptr) throw Error(fmt::format("{}: the PLY data is truncated", path_));
    char* stop = nullptr;
    const double v = std::strtod(word, &stop);
    if (stop != word + length) {
      std::string shown(word, std::min<std::size_t>(length, 40));
      for (char& c : shown) c = c >= 0x20 && c < 0x7f ? c : '?';  // one printable line
      throw Error(fmt::format("{}: the PLY data holds '{}', not a number", path_, shown));
    }
    return v;
  }

  // A list property: its items into `items` when they are a face's vertex indices (p.indices),
  // else read and dropped.
  void list(const Property& p, std::vector<std::uint64_t>& items) {
    items.clear();
    const double claimed = scalar(p.count);
    if (!(claimed >= 0 && claimed <= static_cast<double>(ascii_ ? textSize_ : in_.remaining()))) {
      throw Error(fmt::format("{}: a PLY list claims {} items, more than the file holds", path_, claimed));
    }
    if (claimed != std::floor(claimed)) {
      throw Error(fmt::format("{}: a PLY list claims {} items, not a whole number", path_, claimed));
    }
    const auto count = static_cast<std::uint64_t>(claimed);
    for (std::uint64_t k = 0; k < count; ++k) {
      const double v = scalar(p.scalar);
      // A vertex index is a whole number from 0; a cast would truncate 1.5 and wrap -1.
      if (p.indices && !(v >= 0 && v == std::floor(v) && v < 18446744073709551616.0)) {
        throw Error(fmt::format("{}: a PLY face has the vertex index {}, not a whole number from 0", path_, v));
      }
      if (p.indices) items.push_back(static_cast<std::uint64_t>(v));
    }
  }

 private:
  Input& in_;
  bool ascii_;
  const std::string& path_;
  std::size_t textSize_ = 0;  // ASCII: the bytes after the header
};

// The items of element `e`: each vertex's position and normal, or each face's polygon, into `mesh`.
void readElement(const Element& e, Body& body, IndexedMesh& mesh, const std::string& path) {
  const bool vertex = e.name == "vertex", face = e.name == "face";
  std::vector<std::uint64_t> poly, items;
  for (std::uint64_t n = 0; n < e.count; ++n) {
    throwIfInterruptedEvery(n);
    double xyz[6] = {0, 0, 0, 0, 0, 0};
    bool hasNormal = false;
    poly.clear();
    for (const Property& p : e.properties) {
      if (!p.countType.empty()) {
        body.list(p, items);
        if (p.indices) poly.swap(items);
        continue;
      }
      const double v = body.scalar(p.scalar);
      if (p.role >= 0) {
        xyz[p.role] = v;
        if (p.role >= 3) hasNormal = true;
      }
    }
    if (vertex) {
      mesh.positions.push_back({static_cast<float>(xyz[0]), static_cast<float>(xyz[1]), static_cast<float>(xyz[2])});
      if (hasNormal)
        mesh.normals.push_back({static_cast<float>(xyz[3]), static_cast<float>(xyz[4]), static_cast<float>(xyz[5])});
    } else if (face) {
      addPolygon(mesh, poly, path);
    }
  }
}

}  // namespace

IndexedMesh readPly(const std::string& path, std::string data, MeshMetadata& meta) {
  Input in(path, std::move(data));
  const Header header = parseHeader(in, path, meta);
  checkCounts(header, in.remaining(), path);
  IndexedMesh mesh;
  Body body(in, header.ascii, path);
  for (const Element& e : header.elements) readElement(e, body, mesh, path);
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
    throw Error(fmt::format("{}: the PLY file has {} normals for {} vertices", path, mesh.normals.size(),
                            mesh.positions.size()));
  }
  return mesh;
}

}  // namespace isoslab::format
