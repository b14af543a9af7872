#include "io/label_table.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "core/edit_distance.h"
#include "core/error.h"
#include "core/limits.h"
#include "core/volume_info.h"

namespace isoslab {
namespace {

std::optional<long long> wholeNumber(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (end != s.c_str() + s.size() || errno != 0) return std::nullopt;
  return v;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

const LabelEntry* LabelTable::find(std::int32_t value) const noexcept {
  for (const LabelEntry& e : entries) {
    if (e.value == value) return &e;
  }
  return nullptr;
}

const LabelEntry* LabelTable::findName(const std::string& name) const noexcept {
  for (const LabelEntry& e : entries) {
    if (e.name == name) return &e;
  }
  const std::string wanted = lower(name);
  for (const LabelEntry& e : entries) {
    if (lower(e.name) == wanted) return &e;
  }
  return nullptr;
}

const LabelEntry* LabelTable::nearest(const std::string& name) const noexcept {
  const LabelEntry* best = nullptr;
  std::size_t bestDistance = 0;
  const std::string wanted = lower(name);
  for (const LabelEntry& e : entries) {
    const std::size_t d = editDistance(wanted, lower(e.name));
    if (best == nullptr || d < bestDistance) {
      best = &e;
      bestDistance = d;
    }
  }
  return best;
}

LabelTable readLabelTable(const std::string& path) {
  // The file whole (a table is small): a regular file of at most limits::kMaxLabelTableBytes (a device such
  // as /dev/zero would be read without end), its UTF-8 byte order mark skipped.
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw Error(fmt::format("{}: cannot open the label table", path));
  if (!std::filesystem::is_regular_file(status)) {
    throw Error(fmt::format("{}: the label table is not a regular file", path));
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) throw Error(fmt::format("{}: cannot read the label table", path));
  if (size > limits::kMaxLabelTableBytes) {
    throw Error(fmt::format("{}: the label table is {} bytes; a table may hold {} MiB at most", path, size,
                            limits::kMaxLabelTableBytes >> 20));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the label table", path));
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (in.gcount() != static_cast<std::streamsize>(size))
    throw Error(fmt::format("{}: cannot read the label table", path));
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  if (text.rfind("\xFF\xFE", 0) == 0 || text.rfind("\xFE\xFF", 0) == 0) {
    throw Error(fmt::format("{}: the label table is UTF-16 text; save it as UTF-8", path));
  }
  if (text.find('\0') != std::string::npos) {
    throw Error(fmt::format("{}: the label table holds a NUL byte: it is no text", path));
  }
  LabelTable table;
  std::set<std::int32_t> seen;
  int number = 0;
  // Lines end at \n, \r\n or \r (an old Mac table).
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t end = std::min(text.find_first_of("\r\n", at), text.size());
    const std::string line = text.substr(at, end - at);
    at = end + (text.compare(end, 2, "\r\n") == 0 ? 2 : 1);
    ++number;
    // A comment starts at a '#' outside quotes (an ITK-SNAP name may hold one).
    std::size_t hash = 0;
    for (bool quoted = false; hash < line.size() && (quoted || line[hash] != '#'); ++hash) {
      if (line[hash] == '"') quoted = !quoted;
    }
    const std::string body = line.substr(0, hash);
    std::istringstream fields(body);
    std::vector<std::string> tokens;
    LabelEntry entry;
    const auto quote = body.find('"');
    if (quote != std::string::npos) {  // ITK-SNAP: IDX R G B A VIS MSH "LABEL"
      const auto close = body.find('"', quote + 1);
      if (close == std::string::npos) {
        throw Error(fmt::format("{}:{}: the label's name has no closing quote", path, number));
      }
      entry.name = body.substr(quote + 1, close - quote - 1);
      std::istringstream numbers(body.substr(0, quote));
      for (std::string t; numbers >> t;) tokens.push_back(t);
      if (tokens.size() < 4) {
        throw Error(fmt::format("{}:{}: '{}' is not a label line (IDX R G B A VIS MSH \"LABEL\")", path, number, line));
      }
      tokens.insert(tokens.begin() + 1, entry.name);
    } else {
      for (std::string t; fields >> t;) tokens.push_back(t);
      if (tokens.empty()) continue;
      if (tokens.size() < 2) {
        throw Error(fmt::format("{}:{}: '{}' has no name (INDEX NAME [R G B [A]])", path, number, line));
      }
      entry.name = tokens[1];
    }
    const auto value = wholeNumber(tokens[0]);
    if (!value) {
      throw Error(
          fmt::format("{}:{}: '{}' is not a label line: its first field is not a whole number", path, number, line));
    }
    if (std::abs(static_cast<double>(*value)) > kLargestLabel) {
      throw Error(
          fmt::format("{}:{}: label {} is beyond the labels a map can hold (whole numbers from -{:.0f} to {:.0f})",
                      path, number, *value, kLargestLabel, kLargestLabel));
    }
    entry.value = static_cast<std::int32_t>(*value);
    // A colour when the three fields after the name are whole numbers (mricron's third field is a
    // code, not a colour: one field only).
    if (tokens.size() >= 5) {
      std::array<std::uint8_t, 3> rgb{};
      bool numbers = true;
      for (std::size_t c = 0; c < 3 && numbers; ++c) {
        const auto v = wholeNumber(tokens[2 + c]);
        numbers = v.has_value();
        if (numbers && (*v < 0 || *v > 255)) {
          throw Error(fmt::format("{}:{}: colour component {} is outside 0..255", path, number, *v));
        }
        if (numbers) rgb[c] = static_cast<std::uint8_t>(*v);
      }
      if (numbers) entry.color = rgb;
    }
    if (!seen.insert(entry.value).second) {
      throw Error(fmt::format("{}:{}: label {} is given twice", path, number, entry.value));
    }
    table.entries.push_back(std::move(entry));
  }
  if (table.entries.empty()) throw Error(fmt::format("{}: the label table holds no label", path));
  return table;
}

std::array<std::uint8_t, 3> defaultLabelColor(std::int32_t value) noexcept {
  // Hue by the golden angle, saturation 0.6, value 0.9: neighbouring values differ.
  const double h = std::fmod(static_cast<double>(value) * 137.50776405, 360.0) / 60.0;
  const double hue = h < 0 ? h + 6 : h;
  const double c = 0.9 * 0.6, x = c * (1 - std::abs(std::fmod(hue, 2.0) - 1)), m = 0.9 - c;
  std::array<double, 3> rgb{};
  switch (static_cast<int>(hue) % 6) {
    case 0:
      rgb = {c, x, 0};
      break;
    case 1:
      rgb = {x, c, 0};
      break;
    case 2:
      rgb = {0, c, x};
      break;
    case 3:
      rgb = {0, x, c};
      break;
    case 4:
      rgb = {x, 0, c};
      break;
    default:
      rgb = {c, 0, x};
      break;
  }
  std::array<std::uint8_t, 3> out{};
  for (std::size_t k = 0; k < 3; ++k) out[k] = static_cast<std::uint8_t>(std::lround((rgb[k] + m) * 255));
  return out;
}

}  // namespace isoslab
