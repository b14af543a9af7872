#include "io/file_list.h"

#include <fmt/format.h>
#include <fmt/printf.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <system_error>

#include "core/error.h"

namespace fs = std::filesystem;

namespace isoslab {

bool naturalLess(std::string_view a, std::string_view b) noexcept {
  std::size_t i = 0;
  std::size_t j = 0;
  auto isDigit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
  while (i < a.size() && j < b.size()) {
    if (isDigit(a[i]) && isDigit(b[j])) {
      std::size_t ia = i;
      std::size_t jb = j;
      while (ia < a.size() && a[ia] == '0') ++ia;
      while (jb < b.size() && b[jb] == '0') ++jb;
      std::size_t ea = ia;
      std::size_t eb = jb;
      while (ea < a.size() && isDigit(a[ea])) ++ea;
      while (eb < b.size() && isDigit(b[eb])) ++eb;
      if (ea - ia != eb - jb) return ea - ia < eb - jb;
      const int c = a.substr(ia, ea - ia).compare(b.substr(jb, eb - jb));
      if (c != 0) return c < 0;
      // Equal values: fewer leading zeros first, then go on.
      if (ia - i != jb - j) return ia - i < jb - j;
      i = ea;
      j = eb;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::vector<std::string> listFolder(const std::string& folder) {
  std::error_code ec;
  std::vector<std::string> names;
  fs::directory_iterator it(folder, ec);
  if (ec) throw Error(fmt::format("{}: cannot read folder: {}", folder, ec.message()));
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    if (ec) throw Error(fmt::format("{}: cannot read folder: {}", folder, ec.message()));
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (!it->is_regular_file(ec)) continue;
    names.push_back(name);
  }
  if (names.empty()) throw Error(fmt::format("{}: the folder holds no file", folder));
  std::sort(names.begin(), names.end(), [](const std::string& x, const std::string& y) { return naturalLess(x, y); });
  std::vector<std::string> paths;
  paths.reserve(names.size());
  for (const std::string& n : names) paths.push_back((fs::path(folder) / n).string());
  return paths;
}

bool isSlicePattern(std::string_view pattern) noexcept {
  int conversions = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') continue;
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      ++i;
      continue;
    }
    std::size_t k = i + 1;
    if (k < pattern.size() && (pattern[k] == '0' || pattern[k] == '-' || pattern[k] == '+')) ++k;
    while (k < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[k]))) ++k;
    if (k >= pattern.size()) return false;
    if (pattern[k] != 'd' && pattern[k] != 'i' && pattern[k] != 'u') return false;
    ++conversions;
    i = k;
  }
  return conversions == 1;
}

std::string formatPattern(const std::string& pattern, long index) {
  return fmt::sprintf(pattern, index);
}

namespace {

// The smallest index above `after` whose name exists in the pattern's folder, found by listing the
// folder (not by probing index after index). Empty when none does, or when the conversion is in
// the folder part of the pattern.
std::optional<long> nextPatternIndex(const std::string& pattern, long after) {
  const fs::path p(pattern);
  const std::string name = p.filename().string();
  if (!isSlicePattern(name)) return std::nullopt;
  std::size_t percent = 0;
  while (percent < name.size() && (name[percent] != '%' || (percent + 1 < name.size() && name[percent + 1] == '%'))) {
    percent += name[percent] == '%' ? 2 : 1;
  }
  if (percent >= name.size()) return std::nullopt;
  std::size_t conversion = percent + 1;
  while (conversion < name.size() && std::string_view("diu").find(name[conversion]) == std::string_view::npos) {
    ++conversion;
  }
  const std::string prefix = fmt::sprintf(name.substr(0, percent));  // "%%" becomes "%"
  const std::string suffix = fmt::sprintf(name.substr(conversion + 1));
  const std::string folder = p.parent_path().empty() ? std::string(".") : p.parent_path().string();
  std::error_code ec;
  std::optional<long> best;
  for (fs::directory_iterator it(folder, ec), stop; !ec && it != stop; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (n.size() <= prefix.size() + suffix.size() || n.compare(0, prefix.size(), prefix) != 0 ||
        n.compare(n.size() - suffix.size(), suffix.size(), suffix) != 0) {
      continue;
    }
    const std::string digits = n.substr(prefix.size(), n.size() - prefix.size() - suffix.size());
    if (digits.size() > 18 || !std::all_of(digits.begin(), digits.end(), [](char c) {
          return std::isdigit(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '+' || c == ' ';
        })) {
      continue;
    }
    char* stop2 = nullptr;
    const long index = std::strtol(digits.c_str(), &stop2, 10);
    if (stop2 != digits.c_str() + digits.size() || index <= after || (best && index >= *best)) continue;
    // The name must be the one the pattern gives for that index (not another width of zeros).
    if (formatPattern(name, index) == n && fs::is_regular_file(it->path(), ec)) best = index;
  }
  return best;
}

}  // namespace

std::vector<std::string> expandPattern(const std::string& pattern) {
  std::vector<std::string> paths;
  std::error_code ec;
  long first = -1;
  for (long start : {0L, 1L}) {
    if (fs::is_regular_file(formatPattern(pattern, start), ec)) {
      first = start;
      break;
    }
  }
  if (first < 0) {
    throw Error(fmt::format("{}: the pattern matches no file (tried indices 0 and 1)", pattern));
  }
  long end = first;
  for (;; ++end) {
    std::string p = formatPattern(pattern, end);
    if (!fs::is_regular_file(p, ec)) {
      if (fs::exists(p, ec))
        throw Error(fmt::format("{}: not a regular file (FIFOs, devices and folders are not read)", p));
      break;
    }
    paths.push_back(std::move(p));
  }
  // The first missing index ends the slices, unless a later index has a file: then a slice is
  // missing in the middle, and stopping there would silently drop the rest.
  if (const auto later = nextPatternIndex(pattern, end)) {
    throw Error(fmt::format("{}: missing, but {} follows it: the pattern's slices have a gap",
                            formatPattern(pattern, end), formatPattern(pattern, *later)));
  }
  return paths;
}

}  // namespace isoslab
