// Outputs and the file system: interruption by signals, devices and links as outputs, the report
// beside the mesh (issue 13).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace {

std::string contents(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path freshFolder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("isoslab-output-safety-" + std::to_string(::getpid()) + "-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Runs isoslab with `args` in the background; returns its pid. stderr goes to /dev/null.
pid_t spawn(const std::vector<std::string>& args) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string cli = ISOSLAB_CLI_PATH;
    argv.push_back(cli.data());
    std::vector<std::string> copy = args;
    for (std::string& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::freopen("/dev/null", "w", stderr);
    ::execv(cli.c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

int waitExit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

int run(const std::vector<std::string>& args) {
  return waitExit(spawn(args));
}

std::size_t entries(const fs::path& dir) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

// Waits until a temporary file appears in `dir` (the output is being written), at most 3 s.
void waitForTemporary(const fs::path& dir) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (std::chrono::steady_clock::now() < end && entries(dir) == 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

struct SignalCase {
  std::string output;
  int signal;
  int exitCode;
};

}  // namespace

TEST(OutputSafety, SignalsRemoveEveryTemporaryAndExitWithTheSignalCode) {
  const std::vector<SignalCase> cases = {{"m.ply", SIGINT, 130}, {"m.stl", SIGINT, 130}, {"m.obj", SIGINT, 130},
                                         {"m.glb", SIGINT, 130}, {"m.drc", SIGINT, 130}, {"m.ply", SIGTERM, 143},
                                         {"m.obj", SIGHUP, 129}, {"v.nii", SIGINT, 130}};
  for (const SignalCase& c : cases) {
    SCOPED_TRACE(c.output + " signal " + std::to_string(c.signal));
    const fs::path dir = freshFolder("signal");
    const std::string out = (dir / c.output).string();
    const pid_t pid = c.output == "v.nii" ? spawn({"phantom", "phantom:head?n=400", "-o", out})
                                          : spawn({"extract", "phantom:head?n=400", "-o", out, "-q"});
    if (c.output == "m.glb") {
      // .glb spools to unlinked files and creates its output only at the end: signal mid-run.
      std::this_thread::sleep_for(std::chrono::milliseconds(400));
    } else {
      waitForTemporary(dir);
      ASSERT_GT(entries(dir), 0u) << "the run wrote no temporary file";
    }
    ::kill(pid, c.signal);
    EXPECT_EQ(waitExit(pid), c.exitCode);
    EXPECT_EQ(entries(dir), 0u) << "an output or temporary file remains";
    fs::remove_all(dir);
  }
}

TEST(OutputSafety, ReportEqualToTheOutputIsAUsageError) {
  const fs::path dir = freshFolder("same");
  const std::string mesh = (dir / "m.ply").string();
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", mesh, "--report", mesh, "-q"}), 2);
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", mesh, "--report", (dir / "." / "m.ply").string(), "-q"}), 2);
  fs::create_symlink("m.ply", dir / "link.ply");
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", mesh, "--report", (dir / "link.ply").string(), "-q"}), 2);
  EXPECT_FALSE(fs::exists(mesh));
  fs::remove_all(dir);
}

TEST(OutputSafety, AReportThatCannotBeWrittenLeavesNoMesh) {
  const fs::path dir = freshFolder("report");
  const std::string mesh = (dir / "m.ply").string();
  EXPECT_EQ(
      run({"extract", "phantom:sphere?n=16", "-o", mesh, "--report", (dir / "missing" / "r.json").string(), "-q"}), 1);
  EXPECT_EQ(entries(dir), 0u);
  fs::remove_all(dir);
}

TEST(OutputSafety, ASymlinkKeepsItsLinkAndItsTargetIsReplaced) {
  const fs::path dir = freshFolder("link");
  fs::create_directories(dir / "real");
  std::ofstream(dir / "real" / "r.json") << "old";
  fs::create_symlink("real/r.json", dir / "r.json");
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", (dir / "m.ply").string(), "--report",
                 (dir / "r.json").string(), "-q"}),
            0);
  EXPECT_TRUE(fs::is_symlink(dir / "r.json"));
  EXPECT_GT(fs::file_size(dir / "real" / "r.json"), 100u);
  EXPECT_EQ(entries(dir / "real"), 1u);
  fs::remove_all(dir);
}

TEST(OutputSafety, AFifoAndDevNullAreWrittenInPlace) {
  const fs::path dir = freshFolder("fifo");
  const fs::path fifo = dir / "r.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string read;
  std::thread reader([&] {
    std::ifstream in(fifo);
    read.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  });
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", (dir / "m.ply").string(), "--report", fifo.string(), "-q"}),
            0);
  reader.join();
  EXPECT_NE(read.find("\"generator\""), std::string::npos);
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the FIFO was replaced";
  // /dev/null: a character device that must stay one (checked read-only, whoever runs the test).
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-o", (dir / "n.ply").string(), "--report", "/dev/null", "-q"}), 0);
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  fs::remove_all(dir);
}

// /dev/stdout when stdout is a pipe: the link chain ends at /proc/self/fd/1, whose target is no
// path ("pipe:[N]"); the kernel still opens it, so the mesh goes down the pipe.
TEST(OutputSafety, DevStdoutOnAPipeIsWrittenInPlace) {
  const fs::path dir = freshFolder("pipe");
  fs::create_symlink("/dev/stdout", dir / "out.obj");
  const std::string cmd = std::string(ISOSLAB_CLI_PATH) + " extract 'phantom:sphere?n=16' -q -o " +
                          (dir / "out.obj").string() + " 2>" + (dir / "err").string() + " | cat > " +
                          (dir / "piped.obj").string();
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_EQ(run({"extract", "phantom:sphere?n=16", "-q", "-o", (dir / "file.obj").string()}), 0);
  EXPECT_EQ(contents(dir / "err"), "");
  const std::string piped = contents(dir / "piped.obj");
  EXPECT_GT(piped.size(), 1000u);
  EXPECT_TRUE(piped == contents(dir / "file.obj"));
  fs::remove_all(dir);
}
