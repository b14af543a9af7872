// `isoslab view`: one HTML file that holds three.js, its glTF and Draco loaders, the Draco decoder,
// the .glb and the report, so that it opens from file:// as well as from any web server.
//
// three.js is vendored (npm package `three`, the version below), never fetched: its files are
// found in a folder holding node_modules/three, looked for in order in $ISOSLAB_VIEWER_JS,
// ../share/isoslab/viewer beside the executable, and the build tree's npm folder.
#include "cli/view.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <string_view>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "encode/mesh_reader.h"

namespace isoslab::cli {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kThreeVersion = "0.187.0";

// The page: placeholders @TITLE@ (HTML text) and @DATA@ (a JSON object, '<' escaped).
constexpr std::string_view kPage =
#include "cli/viewer_page.inc"
    ;

// The modules the page imports; their imports are followed from these.
constexpr const char* kEntries[][2] = {
    {"three", "build/three.module.js"},
    {"GLTFLoader", "examples/jsm/loaders/GLTFLoader.js"},
    {"DRACOLoader", "examples/jsm/loaders/DRACOLoader.js"},
    {"OrbitControls", "examples/jsm/controls/OrbitControls.js"},
};
constexpr const char* kDracoDecoder = "examples/jsm/libs/draco/draco_decoder.js";

std::string readFile(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::string bytes;
  char buffer[1 << 16];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) bytes.append(buffer, n);
  const bool failed = std::ferror(f) != 0;
  const int error = errno;
  std::fclose(f);
  if (failed) throw Error(fmt::format("{}: cannot read: {}", path, std::strerror(error != 0 ? error : EIO)));
  return bytes;
}

std::string base64(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const auto v = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16 |
                   static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8 |
                   static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 2]));
    for (int shift = 18; shift >= 0; shift -= 6) out += kAlphabet[(v >> shift) & 63];
  }
  if (const std::size_t rest = bytes.size() - i; rest > 0) {
    unsigned v = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16;
    if (rest == 2) v |= static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string htmlEscape(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// The folder holding node_modules/three, or empty.
std::string findThree(std::vector<std::string>& looked) {
  std::vector<std::string> candidates;
  if (const char* env = std::getenv("ISOSLAB_VIEWER_JS"); env != nullptr && *env != '\0') candidates.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    candidates.push_back((exe.parent_path() / ".." / "share" / "isoslab" / "viewer").lexically_normal().string());
#ifdef ISOSLAB_NPM_DIR
  candidates.emplace_back(ISOSLAB_NPM_DIR);
#endif
  for (const std::string& folder : candidates) {
    looked.push_back(folder);
    if (fs::is_regular_file(fs::path(folder) / "node_modules/three/build/three.module.js", ec)) return folder;
  }
  return "";
}

// The modules one module imports: `import ... from 'x'`, `export ... from 'x'` and `import 'x'`,
// on lines that start a statement or close a multi-line import list (not in comments).
std::vector<std::string> importsOf(const std::string& source) {
  static const std::regex kFrom(R"((?:^|[\s}])from\s*(['"])([^'"]+)\1)");
  static const std::regex kBare(R"(^import\s*(['"])([^'"]+)\1)");
  std::vector<std::string> specs;
  std::size_t start = 0;
  while (start < source.size()) {
    std::size_t end = source.find('\n', start);
    if (end == std::string::npos) end = source.size();
    std::size_t first = source.find_first_not_of(" \t", start);
    if (first < end) {
      const std::string_view head(source.data() + first, end - first);
      if (head.starts_with("import") || head.starts_with("export") || head.starts_with("}")) {
        const std::string line(head);
        std::smatch m;
        if (std::regex_search(line, m, kFrom) || std::regex_search(line, m, kBare)) specs.push_back(m[2].str());
      }
    }
    start = end + 1;
  }
  return specs;
}

struct Module {
  std::string path;  // inside node_modules/three
  std::string source;
  std::map<std::string, std::size_t> imports;  // specifier -> index of the module it names
};

// Collects `path` and what it imports into `modules`, dependencies first; returns its index.
class ModuleGraph {
 public:
  explicit ModuleGraph(fs::path root) : root_(std::move(root)) {}

  std::size_t add(const std::string& path) {
    if (const auto found = index_.find(path); found != index_.end()) {
      if (found->second == kPending)
        throw Error(fmt::format("viewer: {}: an import cycle, which the page cannot load", path));
      return found->second;
    }
    index_[path] = kPending;
    Module module{path, readFile((root_ / path).string()), {}};
    for (const std::string& spec : importsOf(module.source)) {
      module.imports[spec] = add(resolve(path, spec));
    }
    modules.push_back(std::move(module));
    index_[path] = modules.size() - 1;
    return modules.size() - 1;
  }

  std::vector<Module> modules;

 private:
  static constexpr std::size_t kPending = static_cast<std::size_t>(-1);

  std::string resolve(const std::string& from, const std::string& spec) const {
    if (spec == "three") return kEntries[0][1];
    if (spec.starts_with("three/addons/")) return "examples/jsm/" + spec.substr(13);
    if (spec.starts_with("./") || spec.starts_with("../")) {
      const std::string path = (fs::path(from).parent_path() / spec).lexically_normal().generic_string();
      if (!path.starts_with("..")) return path;
    }
    throw Error(fmt::format("viewer: {}: cannot embed its import '{}'", (root_ / from).string(), spec));
  }

  fs::path root_;
  std::map<std::string, std::size_t> index_;
};

}  // namespace

int runView(const std::string& glb, const std::string& report, const std::string& page) {
  // The inputs first, so that a wrong one is named before anything else is looked at.
  const std::string mesh = readFile(glb);
  if (mesh.size() < 12 || mesh.compare(0, 4, "glTF") != 0) {
    throw Error(fmt::format(
        "{}: not a .glb file (binary glTF starts with 'glTF'); view takes the .glb that extract wrote", glb));
  }
  // Decoded once as `decode` reads it, so that a truncated or corrupt .glb is refused here with one
  // line, not by the browser.
  readMeshData(glb, mesh);            // polls for a stop as it decodes
  nlohmann::ordered_json reportJson;  // null when there is none; keeps the report's order
  if (!report.empty()) {
    const std::string text = readFile(report);
    try {
      reportJson = nlohmann::ordered_json::parse(text);
    } catch (const nlohmann::json::exception& e) {
      throw Error(fmt::format("{}: not a JSON report: {}", report, e.what()));
    }
    if (!reportJson.is_object()) throw Error(fmt::format("{}: not a JSON report (not an object)", report));
  }
  const std::string out = page.empty() ? fs::path(glb).replace_extension(".html").string() : page;
  std::error_code ec;
  if (fs::equivalent(out, glb, ec) || (!report.empty() && fs::equivalent(out, report, ec))) {
    throw Error(fmt::format("{}: the page would replace an input", out));
  }

  std::vector<std::string> looked;
  const std::string npm = findThree(looked);
  if (npm.empty()) {
    throw Error(fmt::format(
        "viewer: three.js is not installed; run scripts/setup.sh or npm install in {} (or set ISOSLAB_VIEWER_JS to a "
        "folder holding node_modules/three {}); looked in {}",
        looked.empty() ? std::string("the build tree's npm folder") : looked.back(), kThreeVersion,
        fmt::join(looked, ", ")));
  }
  const fs::path root = fs::path(npm) / "node_modules" / "three";
  {
    nlohmann::json package;
    try {
      package = nlohmann::json::parse(readFile((root / "package.json").string()));
    } catch (const nlohmann::json::exception&) {
    }
    const std::string version = package.is_object() ? package.value("version", std::string()) : std::string();
    if (version != kThreeVersion) {
      throw Error(fmt::format("viewer: {}: three.js {} where the viewer needs {}; run npm install in {}", root.string(),
                              version.empty() ? std::string("of no known version") : version, kThreeVersion, npm));
    }
  }

  ModuleGraph graph(root);
  nlohmann::ordered_json entries = nlohmann::ordered_json::object();
  for (const auto& entry : kEntries) entries[entry[0]] = graph.add(entry[1]);
  nlohmann::ordered_json modules = nlohmann::ordered_json::array();
  for (const Module& m : graph.modules) {
    nlohmann::ordered_json imports = nlohmann::ordered_json::object();
    for (const auto& [spec, index] : m.imports) imports[spec] = index;
    modules.push_back({{"path", m.path}, {"imports", imports}, {"source", base64(m.source)}});
  }

  throwIfInterrupted();  // the page's encoding takes a while for a large mesh
  const std::string name = fs::path(glb).filename().string();
  nlohmann::ordered_json data = {{"name", name},         {"three", kThreeVersion},
                                 {"entries", entries},   {"modules", modules},
                                 {"report", reportJson}, {"draco", base64(readFile((root / kDracoDecoder).string()))},
                                 {"glb", base64(mesh)}};
  // ASCII only, and no '<' (it can only be inside a string): nothing in it can end the <script>.
  std::string json = data.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
  std::string escaped;
  escaped.reserve(json.size());
  for (const char c : json) {
    if (c == '<') {
      escaped += "\\u003c";
    } else {
      escaped += c;
    }
  }
  json.clear();

  // The template's placeholders, found in it (never in what replaces them).
  const std::size_t title = kPage.find("@TITLE@");
  const std::size_t body = kPage.find("@DATA@");
  std::string html;
  html.reserve(kPage.size() + escaped.size() + name.size());
  html.append(kPage.substr(0, title));
  html.append(htmlEscape(name) + " - isoslab viewer");
  html.append(kPage.substr(title + 7, body - title - 7));
  html.append(escaped);
  html.append(kPage.substr(body + 6));

  throwIfInterrupted();
  AtomicFile file(out);
  file.write(html.data(), html.size());
  file.commit();
  // The page is written: a folder that cannot be named absolutely is named as given.
  const fs::path absolute = fs::absolute(out, ec);
  std::fprintf(stderr, "isoslab: viewer page -> %s (open it in a browser; it works from file://)\n",
               (ec ? fs::path(out) : absolute).lexically_normal().string().c_str());
  return 0;
}

}  // namespace isoslab::cli
