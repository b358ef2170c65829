// A full disk, made without root: a child process whose files may not grow
// past RLIMIT_FSIZE, with SIGXFSZ ignored so that a write past the limit
// fails with EFBIG as it fails with ENOSPC on a full disk (docs/formats/run_log.md).
// The run log keeps every row flushed before the failure, still opens, is
// marked complete=0 with the cause, and is under its final name; the process
// exits non-zero with one message naming the cause, the file and the fix, and
// no HDF5 diagnostics. And the log's life cycle: run.h5.part while open,
// run.h5 once closed.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>
#include <opencv2/videoio.hpp>

#include "io/h5_file.h"
#include "io/h5_table.h"
#include "io/run_log.h"
#include "sim/error.h"
#include "tests/io/xml_well_formed.h"
#include "tests/support/h5_plain.h"
#include "tests/support/temporary_folder.h"
#include "tests/support/text_file.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace dg {
namespace {

namespace fs = std::filesystem;
using namespace dg::testing::h5_plain;

using testing::ReadText;

// In a child process, the files written may not grow past `limit_bytes`.
void LimitFileSize(rlim_t limit_bytes) {
  const rlimit limit{limit_bytes, limit_bytes};
  ::setrlimit(RLIMIT_FSIZE, &limit);
  ::signal(SIGXFSZ, SIG_IGN);  // kept across exec
}

struct Finished {
  int status = 0;
  std::string err;  // stderr
};

// The built binary with a file size limit; stdout is dropped.
Finished RunDynaguide(const std::vector<std::string>& args, rlim_t limit_bytes, const std::string& err_path) {
  std::vector<std::string> argv_text = {DG_DYNAGUIDE_PATH};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& arg : argv_text) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int null = ::open("/dev/null", O_WRONLY);
  REQUIRE(err >= 0);
  REQUIRE(null >= 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {  // only async-signal-safe calls until exec: the test process may have threads
    LimitFileSize(limit_bytes);
    ::dup2(null, STDOUT_FILENO);
    ::dup2(err, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(err);
  ::close(null);
  Finished finished;
  REQUIRE(::waitpid(pid, &finished.status, 0) == pid);
  finished.err = ReadText(err_path);
  return finished;
}

// The exit the brief asks of every fault: a code, not a signal (a crash), and not 0.
void RequireCleanFailure(const Finished& finished) {
  INFO(finished.err);
  REQUIRE(WIFEXITED(finished.status));
  REQUIRE(WEXITSTATUS(finished.status) != 0);
  REQUIRE(WEXITSTATUS(finished.status) != 127);  // the binary ran
  CHECK(finished.err.find("HDF5-DIAG") == std::string::npos);
  CHECK_THAT(finished.err, Catch::Contains("File too large"));
  CHECK_THAT(finished.err, Catch::Contains("free space on the output's file system"));
}

bool AnyNamed(const std::string& dir, const std::string& ending) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= ending.size() && name.compare(name.size() - ending.size(), ending.size(), ending) == 0) {
      return true;
    }
  }
  return false;
}

// Limits measured on the 3 s tiny phantom's run (about 50 KiB after the log's
// creation, 1 MiB reserved for the second flush, at frame 59) and the sim's
// built-in problem at 2000 tets (about 60 KiB a step): each lets some flushes
// through and stops the output well before its end.
constexpr rlim_t kRunLogLimitBytes = 640 * 1024;
constexpr rlim_t kSimLimitBytes = 400 * 1024;
// The run log asks for about 130 KiB at its start and 450 KiB at its first
// flush (frame 29); the tiny phantom's annotated frames are about 8.5 KiB
// each, so its video passes this limit near frame 18.
constexpr rlim_t kVideoLimitBytes = 160 * 1024;

// A 3 s tiny phantom (90 frames) generated under `dir`; its scene's path.
std::string TinyPhantomScene(const std::string& dir) {
  tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("tiny");
  spec.duration_s = 3.0;
  tools::phantom::GeneratePhantom(spec, dir + "/phantom", false);
  return dir + "/phantom/scene.yaml";
}

io::RunAttributes Attributes() { return {"test", "offline", "test machine", 1, 30.0}; }

// This process's stderr into a file for the scope's length.
class StderrTo {
 public:
  explicit StderrTo(const std::string& path) : saved_(::dup(STDERR_FILENO)) {
    const int file = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    REQUIRE(file >= 0);
    ::dup2(file, STDERR_FILENO);
    ::close(file);
  }
  ~StderrTo() {
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
  }

 private:
  int saved_;
};

}  // namespace

TEST_CASE("full disk: an HDF5 failure, on any thread, prints nothing and is one error with its cause",
          "[faults][unit]") {
  const testing::TemporaryFolder scratch("dg_full_disk_quiet");
  const std::string& dir = scratch.path();
  const std::string not_hdf5 = dir + "/not.h5";
  std::ofstream(not_hdf5) << "plain text, not HDF5";
  std::string message;
  {
    const StderrTo captured(dir + "/stderr.txt");
    // A thread of its own: HDF5's error printing is set per thread (a thread-safe build).
    std::thread([&] {
      try {
        const io::H5Reader reader(not_hdf5);
      } catch (const Error& e) {
        message = e.what();
      }
    }).join();
  }
  CHECK(ReadText(dir + "/stderr.txt").empty());
  CHECK_THAT(message, Catch::Contains("HDF5 could not open the file: ") && Catch::Contains(not_hdf5) &&
                          Catch::Contains("signature"));
}

TEST_CASE("full disk: a run log is PATH.part while open and PATH once closed", "[faults][unit]") {
  const testing::TemporaryFolder scratch("dg_full_disk_life_cycle");
  const std::string& dir = scratch.path();
  const std::string path = dir + "/run.h5";
  {
    io::RunLog log(path, "scene: text\n", Attributes(), {"capture", "sink"});
    log.AppendTiming(0, 0, 0, 1, 2);
    log.Flush();
    CHECK(fs::exists(path + ".part"));
    CHECK_FALSE(fs::exists(path));
    CHECK(log.path() == path);

    // What a kill -9 leaves: the .part, readable up to the last flush, marked incomplete.
    const hid_t part = H5Fopen((path + ".part").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(part >= 0);
    CHECK(IntAttribute(part, "/", "complete") == 0);
    CHECK_THAT(StringAttribute(part, "/", "error"), Catch::Contains("stopped before it closed its log"));
    CHECK(Rows(part, "/timings/frame") == 1);
    H5Fclose(part);

    log.Finish(true);
    log.Close();
    CHECK(fs::exists(path));
    CHECK_FALSE(fs::exists(path + ".part"));
    log.Close();  // a second Close does nothing
  }
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 1);
  CHECK(StringAttribute(file, "/", "error").empty());
  CHECK(Rows(file, "/timings/frame") == 1);
  H5Fclose(file);

  // Closed without Finish (an exception on the way): renamed, marked incomplete.
  const std::string unfinished = dir + "/unfinished.h5";
  { io::RunLog log(unfinished, "", Attributes(), {"sink"}); }
  CHECK_FALSE(fs::exists(unfinished + ".part"));
  const hid_t closed = H5Fopen(unfinished.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(closed >= 0);
  CHECK(IntAttribute(closed, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(closed, "/", "error"), Catch::Contains("stopped before it closed its log"));
  H5Fclose(closed);
}

TEST_CASE("full disk: a run log keeps the rows flushed before the disk filled", "[faults][unit]") {
  const testing::TemporaryFolder scratch("dg_full_disk_run_log");
  const std::string& dir = scratch.path();
  const std::string path = dir + "/run.h5";
  const std::string report = dir + "/child.txt";
  constexpr int kRowsPerFlush = 500;
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    // The child writes rows of increasing values, flushing every 500, until the limit stops it.
    LimitFileSize(400 * 1024);
    int code = 2;  // never failed
    std::int64_t flushed = 0;
    std::string message;
    {
      io::RunLog log(path, "scene: text\n", Attributes(), {"capture", "sink"});
      io::H5Table& values = log.AddTable("/values", {{"value", io::H5Type::kDouble, 8}});
      try {
        for (std::int64_t row = 0; row < 1'000'000; ++row) {
          std::vector<double> value(8, static_cast<double>(row));
          values.AppendRow({value});
          log.AppendTiming(row, 0, 0, row, row + 1);
          if ((row + 1) % kRowsPerFlush == 0) {
            log.Flush();
            flushed = row + 1;
          }
        }
      } catch (const Error& e) {
        code = 3;
        message = e.what();
        log.Finish(false, message);
      }
    }
    std::ofstream(report) << flushed << "\n" << message;
    ::_exit(code);
  }
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  const std::string child = ReadText(report);
  INFO(child);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 3);
  const hsize_t flushed = std::stoull(child.substr(0, child.find('\n')));
  CHECK(flushed >= kRowsPerFlush);  // some flushes came before the limit
  CHECK_THAT(child, Catch::Contains("File too large") && Catch::Contains(path + ".part") &&
                        Catch::Contains("free space on the output's file system"));

  REQUIRE(fs::exists(path));
  CHECK_FALSE(fs::exists(path + ".part"));
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(file, "/", "error"), Catch::Contains("File too large"));
  // Every flushed row, whole and intact; no row of the failed flush.
  REQUIRE(Rows(file, "/timings/frame") == flushed);
  REQUIRE(Rows(file, "/values/value") == flushed);
  const std::vector<double> values = Doubles(file, "/values/value");
  REQUIRE(values.size() == flushed * 8);
  for (size_t k = 0; k < values.size(); ++k) REQUIRE(values[k] == static_cast<double>(k / 8));
  H5Fclose(file);
}

TEST_CASE("full disk: dynaguide run stops, keeps the frames flushed and exits cleanly", "[faults][integration]") {
  // The log flushed every 30 frames (pipeline/run_log_sink.h).
  const testing::TemporaryFolder scratch("dg_full_disk_run");
  const std::string& dir = scratch.path();
  const std::string out = dir + "/out";
  const Finished finished = RunDynaguide({"run", TinyPhantomScene(dir), "--out", out, "--threads", "2",
                                          "--no-video", "--quiet"},
                                         kRunLogLimitBytes, dir + "/stderr.txt");
  RequireCleanFailure(finished);
  CHECK_THAT(finished.err, Catch::Contains(out + "/run.h5"));

  REQUIRE(fs::exists(out + "/run.h5"));
  CHECK_FALSE(AnyNamed(out, ".part"));
  CHECK_FALSE(AnyNamed(out, ".tmp"));
  const hid_t file = H5Fopen((out + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(file, "/", "error"), Catch::Contains("File too large"));
  // At least the first flush, at frame 29 (its tracks, and the 9 stage
  // timings of the frames before it), and not the whole video.
  const std::vector<double> tracked = Doubles(file, "/tracks/frame");
  REQUIRE_FALSE(tracked.empty());
  const double last_flushed = *std::max_element(tracked.begin(), tracked.end());
  CHECK(last_flushed >= 29);
  CHECK(last_flushed < 89);
  CHECK(Rows(file, "/timings/frame") == static_cast<hsize_t>(last_flushed) * 9);
  H5Fclose(file);
}

TEST_CASE("full disk: the annotated video's failure stops the run, the frames before it playable",
          "[faults][integration]") {
  // The video is the file that fills first (no mesh series); the encoder's
  // error reaches the sink with its next frame.
  const testing::TemporaryFolder scratch("dg_full_disk_video");
  const std::string& dir = scratch.path();
  const std::string out = dir + "/out";
  const Finished finished = RunDynaguide(
      {"run", TinyPhantomScene(dir), "--out", out, "--threads", "2", "--no-mesh-series", "--quiet"},
      kVideoLimitBytes, dir + "/stderr.txt");
  RequireCleanFailure(finished);
  CHECK_THAT(finished.err, Catch::Contains("cannot write the video") && Catch::Contains(out + "/annotated.avi"));

  const hid_t file = H5Fopen((out + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(file, "/", "error"), Catch::Contains("cannot write the video: File too large"));
  H5Fclose(file);
  // The file has no index (the disk had no room for it); FFmpeg reads the
  // frames in the order written.
  cv::VideoCapture reader(out + "/annotated.avi", cv::CAP_FFMPEG);
  REQUIRE(reader.isOpened());
  int frames = 0;
  for (cv::Mat frame; reader.read(frame);) ++frames;
  // 19 of the 160 KiB's frames are whole (the run stopped at frame 21).
  CHECK(frames >= 12);
  CHECK(frames < 30);
}

TEST_CASE("full disk: dynaguide sim stops with its outputs whole and marked incomplete", "[faults][integration]") {
  const testing::TemporaryFolder scratch("dg_full_disk_sim");
  const std::string& dir = scratch.path();
  const std::string out = dir + "/out";
  const Finished finished =
      RunDynaguide({"sim", "--out", out, "--tets", "2000", "--threads", "2", "--quiet"}, kSimLimitBytes,
                   dir + "/stderr.txt");
  RequireCleanFailure(finished);
  CHECK_THAT(finished.err, Catch::Contains(out + "/sim.h5"));

  CHECK_FALSE(AnyNamed(out, ".tmp"));
  // summary.json is whole (it is small enough to fit), marked incomplete.
  const std::string summary = ReadText(out + "/summary.json");
  CHECK_THAT(summary, Catch::StartsWith("{") && Catch::EndsWith("}\n") &&
                          Catch::Contains("\"status\": \"incomplete: error\""));
  // The time series: the steps written before, readable, marked complete=0.
  const hid_t file = H5Fopen((out + "/sim.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  const hsize_t steps = Rows(file, "/time_s");
  CHECK(steps >= 1);
  H5Fclose(file);
  const std::string xmf = ReadText(out + "/sim.xmf");
  CHECK(io::testing::XmlProblem(xmf).empty());
}

}  // namespace dg
