// SIGINT and SIGTERM sent to the built `dynaguide` binary mid-run
// (docs/interrupts.md): the first signal stops the work and the process exits
// 128 + signal with every output finished, readable and marked incomplete;
// a second signal ends the process at once. Each case runs the binary as a
// child process and sends the signal on a line the child printed, never after
// a sleep.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <opencv2/videoio.hpp>

#include "io/registration_file.h"
#include "tests/io/xml_well_formed.h"
#include "tests/support/h5_plain.h"
#include "tests/support/tiny_phantom.h"
#include "tools/sim/builtin_problem.h"

namespace dg {
namespace {

namespace fs = std::filesystem;
using dg::testing::TinyPhantomDir;
using namespace dg::testing::h5_plain;

constexpr char kStopping[] = "dynaguide: stopping after the work in flight (signal again to quit at once)";

// The built binary as a child process, its stdout and stderr read line by line
// through one pipe. A CPU-time limit ends a child that ignores the stop, so a
// broken stop fails the case instead of hanging it.
class Child {
 public:
  explicit Child(const std::vector<std::string>& args) {
    std::vector<std::string> argv_text = {DG_DYNAGUIDE_PATH};
    argv_text.insert(argv_text.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& arg : argv_text) argv.push_back(arg.data());
    argv.push_back(nullptr);
    int fds[2];
    REQUIRE(::pipe(fds) == 0);
    pid_ = ::fork();
    REQUIRE(pid_ >= 0);
    if (pid_ == 0) {  // only async-signal-safe calls until exec: the test process has threads
      const rlimit cpu{60, 60};
      ::setrlimit(RLIMIT_CPU, &cpu);
      ::dup2(fds[1], STDOUT_FILENO);
      ::dup2(fds[1], STDERR_FILENO);
      ::close(fds[0]);
      ::close(fds[1]);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    fd_ = fds[0];
  }
  ~Child() {
    if (fd_ >= 0) ::close(fd_);
    if (pid_ > 0 && !waited_) {  // a failed REQUIRE left it running
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  // Reads until a line for which wanted() holds, and returns it; "" when the output ended first.
  std::string WaitForLine(const std::function<bool(const std::string&)>& wanted) {
    for (std::string line; ReadLine(&line);) {
      if (wanted(line)) return line;
    }
    return {};
  }
  void Signal(int signal) const { REQUIRE(::kill(pid_, signal) == 0); }
  // Reads the output to its end and reaps the child: its wait status.
  int Wait() {
    for (std::string line; ReadLine(&line);) {
    }
    int status = 0;
    REQUIRE(::waitpid(pid_, &status, 0) == pid_);
    waited_ = true;
    return status;
  }
  const std::string& output() const { return output_; }

 private:
  bool ReadLine(std::string* line) {
    for (;;) {
      if (const size_t end = output_.find('\n', consumed_); end != std::string::npos) {
        *line = output_.substr(consumed_, end - consumed_);
        consumed_ = end + 1;
        return true;
      }
      char buffer[4096];
      const ssize_t n = ::read(fd_, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      output_.append(buffer, static_cast<size_t>(n));
    }
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  bool waited_ = false;
  std::string output_;
  size_t consumed_ = 0;
};

// A progress line of the command (sim/progress.cc, not a terminal: one line
// per tenth) at `percent` or beyond.
std::function<bool(const std::string&)> ProgressAtLeast(const std::string& label, int percent) {
  return [=](const std::string& line) {
    std::smatch match;
    return std::regex_search(line, match, std::regex("^" + label + " +([0-9]+)%")) && std::stoi(match[1]) >= percent;
  };
}

size_t Occurrences(const std::string& text, const std::string& part) {
  size_t count = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
  return count;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

// `dynaguide run` on the tiny phantom (30 frames, registered on frame 19),
// paced to the video by the realtime policy so that it lasts about the
// video's second; the signal goes when the 70% progress line arrives: frame
// 20 has reached the sink, so the registration is solved and the simulation
// under way, and a third of the video is still to come.
void CheckRunInterruptedBy(int signal, const std::string& signal_name) {
  const std::string out = TinyPhantomDir() + "/run_" + signal_name;
  Child child({"run", TinyPhantomDir() + "/scene.yaml", "--out", out, "--policy", "realtime", "--threads", "2"});
  INFO(child.output());
  REQUIRE_FALSE(child.WaitForLine(ProgressAtLeast("run", 70)).empty());
  child.Signal(signal);
  const int status = child.Wait();
  INFO(child.output());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 128 + signal);
  CHECK(Occurrences(child.output(), kStopping) == 1);

  // The message, printed once, names the signal and the last frame logged.
  const std::string interrupted = "interrupted by " + signal_name + " at frame ";
  REQUIRE(Occurrences(child.output(), interrupted) == 1);
  std::smatch match;
  REQUIRE(std::regex_search(child.output(), match, std::regex(interrupted + "([0-9]+)")));
  const long long last_frame = std::stoll(match[1]);
  CHECK(last_frame >= 20);  // the 70% line came after frame 20 reached the sink
  CHECK(last_frame < 29);   // stopped before the video's end

  // The log: closed under its own name, marked incomplete with the message,
  // holding every frame up to the last one read (the frames in flight were
  // logged and flushed, not only those before a periodic flush).
  REQUIRE(fs::exists(out + "/run.h5"));
  const hid_t file = H5Fopen((out + "/run.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK_THAT(StringAttribute(file, "/", "error"), Catch::Contains(interrupted + std::to_string(last_frame)));
  const long long frames = IntAttribute(file, "/", "frames");
  CHECK(frames + IntAttribute(file, "/", "frames_dropped") == last_frame + 1);
  CHECK(Rows(file, "/timings/frame") == static_cast<hsize_t>(frames) * 9);  // 9 stages, the sink's included
  const std::vector<double> timed_frames = Doubles(file, "/timings/frame");
  CHECK(*std::max_element(timed_frames.begin(), timed_frames.end()) == last_frame);
  const std::vector<double> simulated = Doubles(file, "/sim/frame");
  REQUIRE_FALSE(simulated.empty());
  CHECK(simulated.back() == last_frame);
  CHECK(IntAttribute(file, "/", "simulated_frames") == static_cast<long long>(simulated.size()));
  const std::vector<double> simulated_t_s = Doubles(file, "/sim/t_s");

  // The registration the run solved, written for a scene to reuse.
  REQUIRE(IntAttribute(file, "/registration", "frame") <= last_frame);
  const std::vector<double> T_C_S = Doubles(file, "/registration/T_C_S");
  const io::Registration registration = io::ReadRegistrationYaml(out + "/registration.yaml");
  for (int k = 0; k < 16; ++k) CHECK(registration.T_C_S(k / 4, k % 4) == Approx(T_C_S[k]).margin(1e-12));

  // The video closed with its index: a player counts the frames it holds.
  const long long video_frames = frames - IntAttribute(file, "/", "video_frames_dropped");
  H5Fclose(file);
  cv::VideoCapture video(out + "/annotated.avi");
  REQUIRE(video.isOpened());
  CHECK(video.get(cv::CAP_PROP_FRAME_COUNT) > 0);
  CHECK(video.get(cv::CAP_PROP_FRAME_COUNT) == video_frames);

  // The mesh series (written by default for so short a run): marked
  // incomplete, holding the frames simulated, and its .xmf lists those alone.
  const hid_t series = H5Fopen((out + "/mesh_series.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(series >= 0);
  CHECK(IntAttribute(series, "/", "complete") == 0);
  CHECK(Doubles(series, "/time_s") == simulated_t_s);
  H5Fclose(series);
  const std::string xmf = ReadText(out + "/mesh_series.xmf");
  CHECK(dg::io::testing::XmlProblem(xmf) == "");
  CHECK(Occurrences(xmf, "<Time Value=") == simulated.size());
}

// The built-in sim problem (20000 tets by default, here 6000) for 20 s with
// an output step every 1 s (5000 steps of 0.2 ms): each output step takes
// long enough that a second signal arrives while the first is still waiting
// for the next one, and the whole problem far longer than any case here.
std::string WriteLongSimProblem(const std::string& dir) {
  std::string text = dg::tools::kBuiltinProblem;
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"duration_s: 1.0", "duration_s: 20.0"},
                                 {"output_every_s: 0.01", "output_every_s: 1.0"},
                                 {"tets: 20000", "tets: 6000"}}) {
    const size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
  }
  fs::create_directories(dir);
  const std::string path = dir + "/problem.yaml";
  std::ofstream(path) << text;
  return path;
}

constexpr long long kStepsPerOutput = 5000;

}  // namespace

TEST_CASE("signals: SIGINT mid-run ends `run` with 130 and every output finished", "[faults][integration]") {
  CheckRunInterruptedBy(SIGINT, "SIGINT");
}

TEST_CASE("signals: SIGTERM mid-run ends `run` with 143 and every output finished", "[faults][integration]") {
  CheckRunInterruptedBy(SIGTERM, "SIGTERM");
}

// The first output step after the signal is the last: summary.json says so,
// and the time series ends there, closed and marked incomplete.
TEST_CASE("signals: SIGTERM mid-run ends `sim` with 143, its outputs marked incomplete", "[faults][integration]") {
  const std::string dir = TinyPhantomDir() + "/sim_sigterm";
  const std::string problem = WriteLongSimProblem(dir);
  Child child({"sim", problem, "--out", dir + "/out", "--threads", "2"});
  INFO(child.output());
  REQUIRE_FALSE(child.WaitForLine(ProgressAtLeast("sim", 0)).empty());  // the first output step is written
  child.Signal(SIGTERM);
  const int status = child.Wait();
  INFO(child.output());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 143);
  CHECK(Occurrences(child.output(), kStopping) == 1);
  std::smatch match;
  REQUIRE(std::regex_search(child.output(), match, std::regex("interrupted by SIGTERM at step ([0-9]+)")));
  const long long step = std::stoll(match[1]);
  CHECK(step % kStepsPerOutput == 0);
  CHECK(step >= kStepsPerOutput);
  CHECK(step < 100000);  // 20 s of 0.2 ms steps: stopped early

  const std::string summary = ReadText(dir + "/out/summary.json");
  CHECK_THAT(summary, Catch::Contains("\"status\": \"incomplete: interrupted by SIGTERM at step " +
                                      std::to_string(step) + "\""));
  CHECK_THAT(summary, Catch::Contains("\"steps\": " + std::to_string(step) + ","));
  const hid_t file = H5Fopen((dir + "/out/sim.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK(Rows(file, "/time_s") == static_cast<hsize_t>(step / kStepsPerOutput + 1));  // the initial state too
  H5Fclose(file);
  CHECK_THAT(ReadText(dir + "/out/sim.xmf"), Catch::Contains("CollectionType=\"Temporal\""));
  CHECK_FALSE(fs::exists(dir + "/out/final.vtu"));  // the final state was not reached
}

// The second signal does not wait for the output step the first one waits
// for: the process ends by the signal's default action, and nothing marks the
// outputs complete.
TEST_CASE("signals: a second SIGINT ends `sim` at once", "[faults][integration]") {
  const std::string dir = TinyPhantomDir() + "/sim_twice";
  const std::string problem = WriteLongSimProblem(dir);
  Child child({"sim", problem, "--out", dir + "/out", "--threads", "2"});
  INFO(child.output());
  REQUIRE_FALSE(child.WaitForLine(ProgressAtLeast("sim", 0)).empty());
  child.Signal(SIGINT);
  REQUIRE_FALSE(child.WaitForLine([](const std::string& line) { return line == kStopping; }).empty());
  child.Signal(SIGINT);
  const int status = child.Wait();
  INFO(child.output());
  REQUIRE(WIFSIGNALED(status));
  CHECK(WTERMSIG(status) == SIGINT);
  CHECK(child.output().find("interrupted by") == std::string::npos);  // it did not get to stop in order

  CHECK_FALSE(fs::exists(dir + "/out/summary.json"));
  const hid_t file = H5Fopen((dir + "/out/sim.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);  // flushed at every output step
  CHECK(IntAttribute(file, "/", "complete") == 0);
  CHECK(Rows(file, "/time_s") >= 2);  // the initial state and the first output step
  H5Fclose(file);
}

}  // namespace dg
