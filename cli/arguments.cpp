#include "cli/arguments.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "job/extract_settings.h"
#include "stream/iso_choice.h"

namespace isoslab::cli {
namespace {

std::optional<std::vector<double>> numbersOf(const std::string& text) {
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v)) return std::nullopt;
    values.push_back(v);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

const std::string* findName(const std::vector<std::string>& names, const std::string& value) {
  const std::string lower = CLI::detail::to_lower(value);
  const auto it = std::find(names.begin(), names.end(), lower);
  return it == names.end() ? nullptr : &*it;
}

}  // namespace

std::string alternatives(const std::vector<std::string>& names) {
  std::string text;
  for (std::size_t n = 0; n < names.size(); ++n) {
    text += (n == 0 ? "" : n + 1 == names.size() ? " or " : ", ") + names[n];
  }
  return text;
}

std::string optionTakenAsValue(const CLI::App& command) {
  for (const CLI::Option* option : command.get_options()) {
    // Flags take no value; positionals get words with dashes only after `--`, where they are meant
    // (batch passes the words after `--` on to extract).
    if (option->get_type_size() == 0 || !option->nonpositional()) continue;
    for (const std::string& value : option->results()) {
      // "--threads=2" names --threads; "-" (standard output) and "-400" name nothing.
      const std::string name = value.substr(0, value.find('='));
      if (name.size() > 1 && name[0] == '-' && command.get_option_no_throw(name) != nullptr) {
        return fmt::format("{} needs a value, not the option {}", option->get_name(), name);
      }
    }
  }
  for (const CLI::App* sub : command.get_subcommands()) {
    if (std::string message = optionTakenAsValue(*sub); !message.empty()) return message;
  }
  return "";
}

CLI::Validator oneOf(const std::string& what, const std::vector<std::string>& names) {
  return CLI::Validator(
      [what, names](std::string& value) -> std::string {
        if (const std::string* name = findName(names, value)) {
          value = *name;
          return {};
        }
        return fmt::format("unknown {} '{}' (use {})", what, value, alternatives(names));
      },
      "");
}

CLI::Validator listOf(const std::string& what, const std::vector<std::string>& names) {
  return CLI::Validator(
      [what, names](std::string& value) -> std::string {
        std::string rewritten;
        std::size_t start = 0;
        while (start <= value.size()) {
          const std::size_t comma = value.find(',', start);
          const std::string item = value.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
          const std::string* name = findName(names, item);
          if (name == nullptr) return fmt::format("unknown {} '{}' (use {})", what, item, alternatives(names));
          rewritten += (rewritten.empty() ? "" : ",") + *name;
          if (comma == std::string::npos) break;
          start = comma + 1;
        }
        value = rewritten;
        return {};
      },
      "");
}

namespace {

// The whole of `value` as a number (strtod's: NaN and infinities too, an overflow as infinite), or
// none when it is not one.
std::optional<double> wholeNumberText(const std::string& value) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size()) return std::nullopt;
  return errno == ERANGE && std::abs(v) > 1 ? std::copysign(INFINITY, v) : v;
}

}  // namespace

CLI::Validator finiteNumber() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const auto v = wholeNumberText(value);
        return v && !std::isfinite(*v) ? fmt::format("'{}' is not a finite number", value) : std::string();
      },
      "");
}

CLI::Validator nonNegativeNumber() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const auto v = wholeNumberText(value);
        return v && std::isfinite(*v) && *v >= 0 ? std::string()
                                                 : fmt::format("'{}' is not a finite number of 0 or more", value);
      },
      "");
}

CLI::Validator isoValue() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        if (value.find(',') != std::string::npos) {
          // Several values: numbers or names, one surface each.
          std::string out;
          for (std::size_t at = 0; at <= value.size();) {
            const std::size_t comma = std::min(value.find(',', at), value.size());
            const std::string item = value.substr(at, comma - at);
            const auto request = parseIsoRequest(item);
            if (!request || request->kind == IsoRequest::Kind::kAuto) {
              return fmt::format("'{}' in '{}' is not a number, bone or skin (a list takes no auto)", item, value);
            }
            const double v = request->kind == IsoRequest::Kind::kNamed ? request->named.hounsfield : request->value;
            out += (out.empty() ? "" : ",") + fmt::format("{}", v);
            at = comma + 1;
          }
          value = out;
          return {};
        }
        if (const auto request = parseIsoRequest(value)) {
          if (request->kind == IsoRequest::Kind::kAuto) value = "auto";
          if (request->kind == IsoRequest::Kind::kNamed) value = request->named.name;
          return {};
        }
        char* end = nullptr;
        std::strtod(value.c_str(), &end);
        if (!value.empty() && end == value.c_str() + value.size()) {
          return fmt::format("'{}' is not a finite number", value);
        }
        std::vector<std::string> names{"auto"};
        for (const NamedIso& named : kNamedIsos) names.emplace_back(named.name);
        return fmt::format("'{}' is not a number, {}", value, alternatives(names));
      },
      "");
}

CLI::Validator integerIn(std::int64_t lo, std::int64_t hi, const std::string& meaning) {
  return CLI::Validator(
      [lo, hi, meaning](std::string& value) -> std::string {
        errno = 0;
        char* end = nullptr;
        const long long v = std::strtoll(value.c_str(), &end, 10);
        if (value.empty() || end != value.c_str() + value.size() || errno == ERANGE || v < lo || v > hi) {
          return fmt::format("'{}' is not a whole number from {} to {}{}", value, lo, hi, meaning);
        }
        return {};
      },
      "");
}

CLI::Validator numberList(std::function<std::string(const std::vector<double>&)> check) {
  return CLI::Validator(
      [check](std::string& value) -> std::string {
        const auto values = numbersOf(value);
        if (!values) return fmt::format("'{}' is not a comma-separated list of numbers", value);
        const std::string problem = check(*values);
        return problem.empty() ? std::string() : fmt::format("'{}' {}", value, problem);
      },
      "");
}

std::vector<double> parseList(const std::string& text, const std::string& option) {
  auto values = numbersOf(text);
  if (!values) throw UsageError(fmt::format("{}: '{}' is not a comma-separated list of numbers", option, text));
  return *std::move(values);
}

CLI::Validator sphereList() {
  return numberList([](const std::vector<double>& v) -> std::string {
    return v.size() == 4 && v[3] > 0 ? "" : "needs cx,cy,cz,r with r > 0";
  });
}

Sphere parseSphere(const std::string& text) {
  const auto v = parseList(text, "--sphere");
  return Sphere{{v.at(0), v.at(1), v.at(2)}, v.at(3)};
}

std::string withFlags(const std::string& text) {
  return settingsAsFlags(text);
}

std::string terminalLine(const std::string& text) {
  std::string line;
  // Control characters, and every byte that does not start a well-formed UTF-8 sequence (stray
  // continuation bytes, overlong forms, surrogates, code points past U+10FFFF, cut sequences), are
  // written as \xNN; well-formed multi-byte characters ("tête.nii") are kept as they are, except
  // the C1 controls U+0080..U+009F, which terminals may act on.
  for (std::size_t at = 0; at < text.size();) {
    const auto u = static_cast<unsigned char>(text[at]);
    auto next = [&](std::size_t k) { return at + k < text.size() ? static_cast<unsigned char>(text[at + k]) : 0; };
    // The length of a well-formed sequence at `at`, 0 if there is none (RFC 3629's table).
    std::size_t length = 0;
    if (u >= 0xc2 && u <= 0xdf) {
      length = (next(1) & 0xc0) == 0x80 && !(u == 0xc2 && next(1) < 0xa0) ? 2 : 0;
    } else if (u >= 0xe0 && u <= 0xef) {
      const unsigned char lo = u == 0xe0 ? 0xa0 : 0x80;
      const unsigned char hi = u == 0xed ? 0x9f : 0xbf;
      length = next(1) >= lo && next(1) <= hi && (next(2) & 0xc0) == 0x80 ? 3 : 0;
    } else if (u >= 0xf0 && u <= 0xf4) {
      const unsigned char lo = u == 0xf0 ? 0x90 : 0x80;
      const unsigned char hi = u == 0xf4 ? 0x8f : 0xbf;
      length = next(1) >= lo && next(1) <= hi && (next(2) & 0xc0) == 0x80 && (next(3) & 0xc0) == 0x80 ? 4 : 0;
    }
    if (length > 0) {
      line.append(text, at, length);
      at += length;
      continue;
    }
    if (u == '\n') {
      line += "\\n";
    } else if (u == '\t') {
      line += "\\t";
    } else if (u == '\r') {
      line += "\\r";
    } else if (u < 0x20 || u >= 0x7f) {
      line += fmt::format("\\x{:02x}", u);
    } else {
      line += static_cast<char>(u);
    }
    ++at;
  }
  return line;
}

}  // namespace isoslab::cli
