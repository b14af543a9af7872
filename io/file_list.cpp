#include "io/file_list.h"

#include <fmt/format.h>
#include <fmt/printf.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
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
  for (long i = first;; ++i) {
    std::string p = formatPattern(pattern, i);
    if (!fs::is_regular_file(p, ec)) {
      if (fs::exists(p, ec))
        throw Error(fmt::format("{}: not a regular file (FIFOs, devices and folders are not read)", p));
      break;
    }
    paths.push_back(std::move(p));
  }
  return paths;
}

}  // namespace isoslab
