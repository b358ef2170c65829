// `dynaguide calibrate`: stereo calibration from chessboard image pairs.
#include <cstdio>
#include <regex>

#include <CLI/CLI.hpp>

#include "io/calibration.h"
#include "sim/error.h"
#include "tools/calibrate/calibration_report.h"
#include "tools/calibrate/stereo_calibration.h"
#include "tools/calibrate/view_pairs.h"
#include "tools/commands.h"

namespace dg::tools {
namespace {

struct CalibrateArguments {
  std::string left, right, pairs;
  std::string board = "9x6";
  double square_m = 0;
  std::string model = "k5";
  double alpha = 0;
  std::string out, json;
};

void RunCalibrateCommand(const CalibrateArguments& args) {
  calibrate::StereoCalibrationOptions options;
  std::smatch match;
  if (!std::regex_match(args.board, match, std::regex(R"((\d+)x(\d+))"))) {
    throw Error("--board must be COLSxROWS of inner corners (got '" + args.board + "')", "--board",
                "write e.g. 9x6 for a board of 10x7 squares");
  }
  options.board_cols = std::stoi(match[1]);
  options.board_rows = std::stoi(match[2]);
  options.square_m = args.square_m;
  options.model = calibrate::ParseDistortionModel(args.model);
  options.alpha = args.alpha;
  if (args.pairs.empty() && (args.left.empty() || args.right.empty())) {
    throw Error("no images given", "--left/--right/--pairs", "give --left and --right patterns, or --pairs DIR");
  }
  const std::vector<calibrate::ViewPair> views =
      args.pairs.empty() ? calibrate::PairsFromPatterns(args.left, args.right)
                         : calibrate::PairsFromDirectory(args.pairs);
  const calibrate::StereoCalibrationReport report = calibrate::CalibrateStereo(views, options);
  io::WriteStereoCalibration(args.out, report.calibration);
  std::fputs(calibrate::DescribeReport(report).c_str(), stdout);
  std::printf("saved %s\n", args.out.c_str());
  if (!args.json.empty()) {
    calibrate::WriteReportJson(args.json, report);
    std::printf("saved %s\n", args.json.c_str());
  }
}

}  // namespace

void AddCalibrateCommand(CLI::App& app) {
  auto args = std::make_shared<CalibrateArguments>();
  CLI::App* command = app.add_subcommand("calibrate", "Stereo calibration (Zhang) from chessboard image pairs");
  CLI::Option* left = command->add_option("--left", args->left, "Left images: a glob ('dir/left*.png', quoted) or left_%02d.png");
  CLI::Option* right = command->add_option("--right", args->right, "Right images, matching --left in sorted order");
  CLI::Option* pairs = command->add_option("--pairs", args->pairs, "A directory of left*/right* images with equal suffixes");
  pairs->excludes(left)->excludes(right);
  left->needs(right);
  right->needs(left);
  command->add_option("--board", args->board, "Inner corners COLSxROWS")->capture_default_str();
  command->add_option("--square", args->square_m, "Square side, metres")->required()->check(CLI::PositiveNumber);
  command->add_option("--model", args->model, "Distortion model: k4 (k1 k2 p1 p2), k5 (and k3) or k8 (rational)")
      ->check(CLI::IsMember({"k4", "k5", "k8"}))
      ->capture_default_str();
  command->add_option("--alpha", args->alpha, "Rectification scaling: 0 only valid pixels, 1 all pixels")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  command->add_option("--out", args->out, "Calibration YAML (OpenCV FileStorage)")->required();
  command->add_option("--json", args->json, "Also write the figures as JSON");
  command->callback([args] { RunCalibrateCommand(*args); });
}

}  // namespace dg::tools
