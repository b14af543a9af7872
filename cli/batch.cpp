#include "cli/batch.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "cli/arguments.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "metrics/report.h"

extern char** environ;

namespace isoslab::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Item {
  std::size_t index = 0;  // in the list, from 0
  std::string input;
  std::string name;
};

struct Outcome {
  std::size_t index = 0;
  int exitCode = -1;
  double seconds = 0;
  std::string error;  // the child's error line(s), without "isoslab: error: "
  std::vector<std::string> warnings;
  nlohmann::json triangles;  // from the report; null when it failed
};

std::vector<Item> readList(const std::string& list) {
  std::ifstream in(list);
  if (!in) throw Error(fmt::format("{}: cannot open: {}", list, std::strerror(errno)));
  std::vector<Item> items;
  std::map<std::string, int> seen;
  std::set<std::string> given;
  std::string line;
  std::size_t lineNumber = 0;
  while (std::getline(in, line)) {
    ++lineNumber;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    Item item;
    item.index = items.size();
    item.input = line.substr(first, last - first + 1);
    item.name = batchName(item.input);
    // Two inputs of one name: the later ones get -2, -3, ... in list order (the same on every rank),
    // skipping names already given (a.nii, a.nrrd and a-2.nii give a, a-2 and a-2-2).
    const std::string base = item.name;
    for (int n = ++seen[base]; given.count(item.name) != 0; n = ++seen[base]) item.name = fmt::format("{}-{}", base, n);
    given.insert(item.name);
    items.push_back(std::move(item));
  }
  if (in.bad()) throw Error(fmt::format("{}: cannot read: {}", list, std::strerror(errno)));
  if (items.empty()) throw Error(fmt::format("{}: lists no input (one per line; # starts a comment)", list));
  return items;
}

std::string selfPath() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error(fmt::format("cannot find the isoslab program: {}", ec.message()));
  return p.string();
}

// The environment without MPI's variables: a child `isoslab extract` must not take itself for a
// rank of this job.
std::vector<std::string> childEnvironment() {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string_view v(*e);
    if (v.starts_with("OMPI_") || v.starts_with("PMIX_") || v.starts_with("PMI_")) continue;
    env.emplace_back(v);
  }
  return env;
}

class Runner {
 public:
  Runner(const BatchArgs& args) : args_(args), self_(selfPath()), env_(childEnvironment()) {}

  // Starts `item`'s extraction; its stderr goes to a file in the batch folder, removed after.
  pid_t start(const Item& item) {
    std::vector<std::string> argv{self_, "extract", item.input};
    argv.insert(argv.end(), args_.extract.begin(), args_.extract.end());
    argv.insert(argv.end(), {"-q", "-o", meshPath(item), "--report", reportPath(item)});
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    std::vector<char*> cenv;
    for (auto& e : env_) cenv.push_back(e.data());
    cenv.push_back(nullptr);
    posix_spawn_file_actions_t files;
    posix_spawn_file_actions_init(&files);
    posix_spawn_file_actions_addopen(&files, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&files, 1, "/dev/null", O_WRONLY, 0);
    const std::string err = errPath(item);
    posix_spawn_file_actions_addopen(&files, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    // Each child in a process group of its own: a terminal's Ctrl-C then reaches the batch alone,
    // which passes it on once (stopSignal). Reaching a child twice, it would end it at once.
    posix_spawnattr_t attributes;
    posix_spawnattr_init(&attributes);
    posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attributes, 0);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, self_.c_str(), &files, &attributes, cargv.data(), cenv.data());
    posix_spawnattr_destroy(&attributes);
    posix_spawn_file_actions_destroy(&files);
    if (rc != 0) throw Error(fmt::format("{}: cannot start isoslab extract: {}", item.input, std::strerror(rc)));
    started_[pid] = {item.index, Clock::now()};
    return pid;
  }

  // Waits for one child; its outcome. A stop signal is passed on to every running child, which
  // then removes its temporary files and ends within a second.
  Outcome wait(const std::vector<Item>& items) {
    int status = 0;
    pid_t pid = -1;
    for (;;) {
      pid = ::waitpid(-1, &status, WNOHANG);
      if (pid > 0 || (pid < 0 && errno != EINTR)) break;
      if (const int signal = gInterruptSignal.load(); signal != 0 && !stopped_) {
        for (const auto& [child, started] : started_) ::kill(child, signal);
        stopped_ = true;
      }
      // waitpid() would resume after the signal handler (SA_RESTART): poll instead.
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (pid < 0) throw Error(fmt::format("waiting for isoslab extract: {}", std::strerror(errno)));
    const auto [index, began] = started_.at(pid);
    started_.erase(pid);
    const Item& item = items[index];
    Outcome o;
    o.index = index;
    o.seconds = std::chrono::duration<double>(Clock::now() - began).count();
    o.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::ifstream err(errPath(item));
    std::string line;
    while (std::getline(err, line)) {
      if (line.starts_with("isoslab: error: ")) {
        o.error += (o.error.empty() ? "" : "; ") + line.substr(16);
      } else if (line.starts_with("isoslab: warning: ")) {
        o.warnings.push_back(line.substr(18));
      } else if (!line.empty() && o.exitCode != 0) {
        o.error += (o.error.empty() ? "" : "; ") + line;
      }
    }
    std::error_code ec;
    fs::remove(errPath(item), ec);
    if (o.exitCode != 0 && o.error.empty()) o.error = fmt::format("isoslab extract ended with status {}", o.exitCode);
    if (o.exitCode == 0) {
      std::ifstream report(reportPath(item));
      const auto r = nlohmann::json::parse(report, nullptr, false);
      if (!r.is_discarded() && r.contains("triangles")) o.triangles = r["triangles"];
    }
    return o;
  }

  bool busy() const noexcept { return !started_.empty(); }
  std::string meshPath(const Item& item) const { return fmt::format("{}/{}.{}", args_.out, item.name, args_.format); }
  std::string reportPath(const Item& item) const { return fmt::format("{}/{}.json", args_.out, item.name); }

 private:
  std::string errPath(const Item& item) const { return fmt::format("{}/.{}.stderr", args_.out, item.name); }

  const BatchArgs& args_;
  std::string self_;
  std::vector<std::string> env_;
  std::map<pid_t, std::pair<std::size_t, Clock::time_point>> started_;
  bool stopped_ = false;  // a stop signal was passed on to the children
};

nlohmann::json toJson(const Outcome& o) {
  return {{"index", o.index}, {"exit_code", o.exitCode}, {"seconds", o.seconds},
          {"error", o.error}, {"warnings", o.warnings},  {"triangles", o.triangles}};
}

Outcome fromJson(const nlohmann::json& j) {
  Outcome o;
  o.index = j.at("index").get<std::size_t>();
  o.exitCode = j.at("exit_code").get<int>();
  o.seconds = j.at("seconds").get<double>();
  o.error = j.at("error").get<std::string>();
  o.warnings = j.at("warnings").get<std::vector<std::string>>();
  o.triangles = j.at("triangles");
  return o;
}

std::vector<std::byte> bytesOf(const std::string& text) {
  const auto* p = reinterpret_cast<const std::byte*>(text.data());
  return {p, p + text.size()};
}

std::string textOf(const std::vector<std::byte>& bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

}  // namespace

std::string batchName(const std::string& input) {
  std::string name;
  if (input.starts_with("phantom:")) {
    name = input.substr(8);
  } else {
    fs::path p(input);
    if (!p.has_filename()) p = p.parent_path();  // a folder given as "dir/"
    name = p.filename().string();
    if (name.ends_with(".gz")) name.resize(name.size() - 3);
    static const std::set<std::string> kVolume{".nii", ".nrrd", ".nhdr", ".mha", ".mhd", ".raw",
                                               ".tif", ".tiff", ".dcm",  ".img", ".hdr", ".vol"};
    const auto dot = name.rfind('.');
    if (dot != std::string::npos && dot > 0) {
      std::string ext = name.substr(dot);
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (kVolume.count(ext) != 0) name.resize(dot);
    }
  }
  for (char& c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (!(std::isalnum(u) || c == '.' || c == '-' || c == '_')) c = '_';
  }
  if (name.empty() || name == "." || name == "..") name = "input";
  return name;
}

int runBatch(const BatchArgs& args, RankGroup* ranks) {
  for (const std::string& a : args.extract) {
    if (a == "-o" || a == "--output" || a.starts_with("--output=") || a == "--report" || a.starts_with("--report=")) {
      throw UsageError(
          fmt::format("batch: '{}' is set for each input (DIR/NAME.{} and DIR/NAME.json)", a, args.format));
    }
  }
  const int rank = ranks != nullptr ? ranks->rank() : 0;
  const int size = ranks != nullptr ? ranks->size() : 1;
  const std::vector<Item> items = readList(args.list);
  std::error_code ec;
  const bool outExisted = fs::exists(args.out, ec);
  makeOutputFolder(args.out);

  // This rank's inputs, `jobs` at a time. An input that cannot start is a failed input; anything
  // else that fails here, under mpirun, ends every rank (the others wait for this one's results).
  Runner runner(args);
  std::vector<Outcome> outcomes;
  std::size_t next = static_cast<std::size_t>(rank);
  int running = 0;
  try {
    while (next < items.size() || running > 0) {
      if (next < items.size() && running < std::max(1, args.jobs) && gInterruptSignal.load() == 0) {
        const Item& item = items[next];
        next += static_cast<std::size_t>(size);
        try {
          runner.start(item);
          ++running;
        } catch (const Error& e) {
          Outcome o;
          o.index = item.index;
          o.exitCode = 1;
          o.error = e.what();
          outcomes.push_back(std::move(o));
        }
        continue;
      }
      if (running == 0) break;  // interrupted: start nothing more
      outcomes.push_back(runner.wait(items));
      --running;
    }
    throwIfInterrupted();
  } catch (const std::exception& e) {
    // Interrupted: the children removed their temporary files; the folder goes too if this run
    // made it and nothing finished in it. Inputs that finished before the signal keep their
    // outputs, complete (their mesh and report), and batch.json is not written.
    if (gInterruptSignal.load() != 0 && !outExisted) fs::remove(args.out, ec);  // only when empty
    if (ranks != nullptr && gInterruptSignal.load() == 0) {
      std::fprintf(stderr, "isoslab: error: batch: %s (rank %d; every rank stops)\n", e.what(), rank);
      ranks->abort(1);
    }
    if (ranks != nullptr) ranks->abort(128 + gInterruptSignal.load());
    throw;
  }

  // Rank 0 gathers every rank's outcomes, in rank order.
  if (rank > 0) {
    nlohmann::json mine = nlohmann::json::array();
    for (const Outcome& o : outcomes) mine.push_back(toJson(o));
    ranks->send(0, bytesOf(mine.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)));
    const std::string verdict = textOf(ranks->receive(0));
    return verdict == "0" ? 0 : 1;
  }
  for (int q = 1; q < size; ++q) {
    const auto theirs = nlohmann::json::parse(textOf(ranks->receive(q)));
    for (const auto& j : theirs) outcomes.push_back(fromJson(j));
  }
  std::sort(outcomes.begin(), outcomes.end(), [](const Outcome& a, const Outcome& b) { return a.index < b.index; });
  std::size_t failed = 0;
  nlohmann::ordered_json summary;
  summary["list"] = args.list;
  summary["format"] = args.format;
  summary["extract_options"] = args.extract;
  summary["ranks"] = size;
  summary["jobs"] = args.jobs;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  std::string table = "| # | input | status | triangles | seconds | output |\n|---|---|---|---|---|---|\n";
  for (const Outcome& o : outcomes) {
    const Item& item = items[o.index];
    const bool ok = o.exitCode == 0;
    failed += ok ? 0 : 1;
    nlohmann::ordered_json row;
    row["input"] = item.input;
    row["status"] = ok ? "ok" : "failed";
    row["exit_code"] = o.exitCode;
    row["output"] = ok ? nlohmann::ordered_json(runner.meshPath(item)) : nlohmann::ordered_json();
    row["report"] = ok ? nlohmann::ordered_json(runner.reportPath(item)) : nlohmann::ordered_json();
    row["triangles"] = o.triangles;
    row["seconds"] = o.seconds;
    row["error"] = ok ? nlohmann::ordered_json() : nlohmann::ordered_json(o.error);
    row["warnings"] = o.warnings;
    rows.push_back(row);
    table +=
        fmt::format("| {} | {} | {} | {} | {:.2f} | {} |\n", o.index + 1, item.input, ok ? "ok" : "failed: " + o.error,
                    o.triangles.is_null() ? "" : o.triangles.dump(), o.seconds, ok ? runner.meshPath(item) : "");
  }
  summary["inputs"] = rows.size();
  summary["failed"] = failed;
  summary["results"] = rows;
  {
    AtomicFile f(args.out + "/batch.json");
    const std::string text = reportText(summary, args.out + "/batch.json") + "\n";
    f.write(text.data(), text.size());
    f.commit();
  }
  if (!args.quiet) std::fputs(table.c_str(), stdout);
  const int code = failed == 0 ? 0 : 1;
  for (int q = 1; q < size; ++q) ranks->send(q, bytesOf(std::to_string(code)));
  if (failed > 0) {
    std::fprintf(stderr, "isoslab: batch: %zu of %zu inputs failed (%s/batch.json)\n", failed, items.size(),
                 args.out.c_str());
  }
  return code;
}

}  // namespace isoslab::cli
