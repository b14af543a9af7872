// The README's option tables against `isoslab SUB --help`: the same options, and the same defaults.
#include <gtest/gtest.h>

#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.h"

namespace isoslab {
namespace {

// One option or positional as --help lists it; `defaultValue` is what capture_default_str shows
// (CLI11 2.1 prints it after the type: "INT=524288", "TEXT:{on,off}=on").
struct HelpOption {
  std::string name;
  bool hasDefault = false;
  std::string defaultValue;
};

// One row of a README option table: the option's name and the whole row's text.
struct ReadmeRow {
  std::string name;
  std::string text;
};

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(' ');
  const auto e = s.find_last_not_of(' ');
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

// The long name of "-o,--output" (or the only one), or a positional's name.
std::string optionName(const std::string& names) {
  std::string first;
  std::string token;
  std::istringstream in(names);
  while (std::getline(in, token, ',')) {
    token = trim(token);
    if (token.rfind("--", 0) == 0) return token;
    if (first.empty()) first = token;
  }
  return first;
}

// CLI11's help: an entry is indented by two spaces; its names, type (with "=default") and REQUIRED
// fill a 30-character column, or the whole line when longer (the description then follows on the
// next line, indented by 30). A flag's names may carry "{false}", its value when given.
constexpr std::size_t kHelpColumn = 30;

std::vector<HelpOption> parseHelp(const std::string& help) {
  std::vector<HelpOption> options;
  const std::vector<std::string> ls = lines(help);
  std::string section;
  for (std::size_t n = 0; n < ls.size(); ++n) {
    const std::string& line = ls[n];
    if (!line.empty() && line.back() == ':' && line[0] != ' ') {
      section = line;
      continue;
    }
    if (line.size() < 3 || line.compare(0, 2, "  ") != 0 || line[2] == ' ') continue;
    if (section == "Subcommands:") continue;
    const bool continued = n + 1 < ls.size() && ls[n + 1].compare(0, kHelpColumn, std::string(kHelpColumn, ' ')) == 0;
    const std::string left = trim(continued ? line : line.substr(0, kHelpColumn));
    HelpOption o;
    std::istringstream in(left);
    std::string names, type;
    in >> names >> type;
    o.name = optionName(names.substr(0, names.find('{')));
    int depth = 0;
    for (std::size_t i = 0; i < type.size(); ++i) {
      if (type[i] == '{') ++depth;
      if (type[i] == '}') --depth;
      if (type[i] == '=' && depth == 0) {
        o.hasDefault = true;
        o.defaultValue = type.substr(i + 1);
        break;
      }
    }
    if (o.name != "--help") options.push_back(o);
  }
  return options;
}

std::vector<std::string> helpSubcommands(const std::string& help) {
  std::vector<std::string> names;
  bool in = false;
  for (const std::string& line : lines(help)) {
    if (!line.empty() && line[0] != ' ') in = line == "Subcommands:";
    if (in && line.size() > 2 && line.compare(0, 2, "  ") == 0) names.push_back(line.substr(2, line.find(' ', 2) - 2));
  }
  return names;
}

// Splits a Markdown table row on the bars that are not escaped.
std::vector<std::string> cells(const std::string& row) {
  std::vector<std::string> out;
  std::string cell;
  for (std::size_t i = 1; i < row.size(); ++i) {
    if (row[i] == '\\' && i + 1 < row.size() && row[i + 1] == '|') {
      cell += '|';
      ++i;
    } else if (row[i] == '|') {
      out.push_back(trim(cell));
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  return out;
}

// "`-o, --output`" -> "--output"; "`--raw-dims X,Y[,Z]`" -> "--raw-dims"; "`INPUT...`" -> "INPUT".
std::string rowName(const std::string& cell) {
  const auto a = cell.find('`');
  const auto b = cell.find('`', a + 1);
  const std::string code = a == std::string::npos || b == std::string::npos ? cell : cell.substr(a + 1, b - a - 1);
  std::istringstream in(code);
  std::string token, first;
  while (in >> token) {
    if (!token.empty() && token.back() == ',') token.pop_back();
    if (token.rfind("--", 0) == 0) return token;
    if (first.empty()) first = token;
  }
  if (first.size() > 3 && first.compare(first.size() - 3, 3, "...") == 0) first.resize(first.size() - 3);
  return first;
}

// The option tables ("| option | meaning |") of each subcommand: those in its "### `isoslab SUB`"
// section, and those whose introducing line says "(also for `SUB`)".
std::map<std::string, std::vector<ReadmeRow>> readmeTables(const std::string& readme) {
  std::map<std::string, std::vector<ReadmeRow>> tables;
  const std::regex heading("^### `isoslab (\\w+)`");
  const std::regex alsoFor("also for `(\\w+)`");
  std::string section;
  std::string intro;
  const std::vector<std::string> ls = lines(readme);
  for (std::size_t n = 0; n < ls.size(); ++n) {
    std::smatch m;
    if (std::regex_search(ls[n], m, heading)) {
      section = m[1];
      continue;
    }
    if (ls[n].rfind("#", 0) == 0) section.clear();
    if (ls[n].rfind("| option |", 0) != 0) {
      if (!trim(ls[n]).empty()) intro = ls[n];
      continue;
    }
    std::set<std::string> owners;
    if (!section.empty()) owners.insert(section);
    for (auto it = std::sregex_iterator(intro.begin(), intro.end(), alsoFor); it != std::sregex_iterator(); ++it) {
      owners.insert((*it)[1]);
    }
    for (n += 2; n < ls.size() && ls[n].rfind("|", 0) == 0; ++n) {
      const std::vector<std::string> c = cells(ls[n]);
      ReadmeRow row{rowName(c.at(0)), ls[n]};
      for (const std::string& owner : owners) tables[owner].push_back(row);
    }
    intro.clear();
  }
  return tables;
}

std::string regexEscape(const std::string& s) {
  static const std::regex special(R"([.^$|()\[\]{}*+?\\])");
  return std::regex_replace(s, special, R"(\$&)");
}

// Whether the README row states `value` as the default: "default V", "default: V", "`V` (default",
// or "`V` (..., default" (with or without backticks around V in the first two).
bool statesDefault(const std::string& row, const std::string& value) {
  const std::string v = regexEscape(value);
  const std::regex after("default:? `?" + v + "`?([^\\w.,]|[.,](\\s|$)|$)");
  const std::regex before("`" + v + "` \\([^)]*default");
  return std::regex_search(row, after) || std::regex_search(row, before);
}

// Every disagreement between a subcommand's --help and its README rows, one line each.
std::vector<std::string> mismatches(const std::string& sub, const std::vector<HelpOption>& help,
                                    const std::vector<ReadmeRow>& rows) {
  std::vector<std::string> problems;
  std::map<std::string, const ReadmeRow*> byName;
  for (const ReadmeRow& r : rows) byName[r.name] = &r;
  std::set<std::string> listed;
  for (const HelpOption& o : help) {
    listed.insert(o.name);
    const auto it = byName.find(o.name);
    if (it == byName.end()) {
      problems.push_back(sub + ": " + o.name + " is in --help but in no README table");
    } else if (o.hasDefault && !statesDefault(it->second->text, o.defaultValue)) {
      problems.push_back(sub + ": " + o.name + ": --help says the default is '" + o.defaultValue +
                         "', the README row does not: " + it->second->text);
    }
  }
  for (const ReadmeRow& r : rows) {
    if (listed.count(r.name) == 0) problems.push_back(sub + ": " + r.name + " is in the README but not in --help");
  }
  return problems;
}

TEST(Readme, OptionTablesAgreeWithEveryCommandsHelp) {
  const std::string readme = testing::slurp(ISOSLAB_README_PATH);
  ASSERT_FALSE(readme.empty()) << ISOSLAB_README_PATH;
  const auto tables = readmeTables(readme);
  const auto top = testing::runCli("--help");
  ASSERT_EQ(top.exitCode, 0);
  const std::vector<std::string> subs = helpSubcommands(top.out);
  ASSERT_GE(subs.size(), 6u) << top.out;
  for (const std::string& sub : subs) {
    const auto r = testing::runCli(sub + " --help");
    ASSERT_EQ(r.exitCode, 0) << sub;
    const std::vector<HelpOption> help = parseHelp(r.out);
    EXPECT_FALSE(help.empty()) << sub;
    const auto it = tables.find(sub);
    const std::vector<ReadmeRow> rows = it == tables.end() ? std::vector<ReadmeRow>{} : it->second;
    for (const std::string& p : mismatches(sub, help, rows)) ADD_FAILURE() << p;
  }
}

TEST(Readme, TheCheckCatchesMissingRowsAndADefaultThatDrifted) {
  const std::string help =
      "Usage: isoslab extract [OPTIONS] INPUT...\n\nPositionals:\n"
      "  INPUT TEXT ... REQUIRED     Volume\n\nOptions:\n"
      "  -h,--help                   Print this help message and exit\n"
      "  --method TEXT:{mc,mt5}=mc   mc, mt5, mt6 or bcc12\n"
      "  -o,--output TEXT REQUIRED   Output mesh\n\nDraco output:\n"
      "  --chunk-triangles INT=524288\n"
      "                              Draco .glb: triangles per chunk\n";
  const std::vector<HelpOption> options = parseHelp(help);
  ASSERT_EQ(options.size(), 4u);
  EXPECT_EQ(options[0].name, "INPUT");
  EXPECT_EQ(options[1].defaultValue, "mc");
  EXPECT_EQ(options[2].name, "--output");
  EXPECT_FALSE(options[2].hasDefault);
  EXPECT_EQ(options[3].defaultValue, "524288");
  const std::string readme =
      "### `isoslab extract`\n\n| option | meaning |\n|---|---|\n"
      "| `INPUT...` | the volume |\n"
      "| `--method` | `mc` (Marching Cubes, default), `mt5`, `mt6` or `bcc12` |\n"
      "| `--chunk-triangles N` | `.glb`: a chunk closes after N triangles (default 1048576) |\n"
      "| `--draco on\\|off` | Draco or plain |\n\n### Output formats\n";
  const auto rows = readmeTables(readme).at("extract");
  const std::vector<std::string> problems = mismatches("extract", options, rows);
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_EQ(problems[0], "extract: --output is in --help but in no README table");
  EXPECT_EQ(problems[1].rfind("extract: --chunk-triangles: --help says the default is '524288', the README row "
                              "does not: ",
                              0),
            0u)
      << problems[1];
  EXPECT_EQ(problems[2], "extract: --draco is in the README but not in --help");
  EXPECT_TRUE(statesDefault("| `--draco-level L` | level; default 7 (see x) |", "7"));
  EXPECT_FALSE(statesDefault("| `--draco-level L` | level; default 70 |", "7"));
  EXPECT_TRUE(statesDefault("| `--space` | `physical` (default: the input's frame) |", "physical"));
  EXPECT_TRUE(statesDefault("| `--raw-offset N` | bytes; default 0 |", "0"));
}

}  // namespace
}  // namespace isoslab
