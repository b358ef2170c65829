#include "tools/eval/stability_report.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <tuple>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"

namespace dg::tools {
namespace {

// The grid's axes as the results span them, each sorted.
struct Axes {
  std::vector<double> youngs, poissons, dts;
  std::vector<std::string> motions;  // in StudyMotions() order
  std::vector<Guard> guards;
};

Axes AxesOf(const std::vector<CellResult>& cells) {
  std::set<double> E, nu, dt;
  std::set<int> guards;
  std::set<std::string> motions;
  for (const CellResult& c : cells) {
    E.insert(c.spec.youngs_modulus_pa);
    nu.insert(c.spec.poissons_ratio);
    dt.insert(c.spec.dt_s);
    guards.insert(static_cast<int>(c.spec.guard));
    motions.insert(c.spec.motion);
  }
  Axes axes{{E.begin(), E.end()}, {nu.begin(), nu.end()}, {dt.begin(), dt.end()}, {}, {}};
  for (const std::string& m : StudyMotions()) {
    if (motions.count(m)) axes.motions.push_back(m);
  }
  for (int g : guards) axes.guards.push_back(static_cast<Guard>(g));
  return axes;
}

using CellKey = std::tuple<std::string, int, double, double, double>;
CellKey KeyOf(const CellSpec& s) {
  return {s.motion, static_cast<int>(s.guard), s.youngs_modulus_pa, s.poissons_ratio, s.dt_s};
}

std::string Modulus(double E) {
  // The cell name's own spelling (3k, 1M).
  const std::string name = CellSpec{E, 0.45, 1e-3, "default", Guard::kOff}.Name();
  return name.substr(1, name.find('_') - 1);
}

std::string Ms(double seconds, int digits = 3) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*g", digits, seconds * 1e3);
  return text;
}

// The short form of an outcome in the markdown tables.
std::string Short(const CellResult& c) {
  switch (c.outcome) {
    case CellOutcome::kStable:
      return "stable";
    case CellOutcome::kRefused:
      return "refused";
    case CellOutcome::kSubstepped:
      return Printed("x%d", c.substeps);
    case CellOutcome::kInversion:
      return "**inversion**";
    case CellOutcome::kBlowUp:
      return c.detector == "study" ? "**blow-up (study)**" : "**blow-up**";
  }
  return "?";
}

// One colour (BGR) per outcome, Tableau 10: green, grey, blue, orange, red.
cv::Scalar OutcomeColour(CellOutcome outcome) {
  switch (outcome) {
    case CellOutcome::kStable:
      return {44, 160, 44};
    case CellOutcome::kRefused:
      return {170, 170, 170};
    case CellOutcome::kSubstepped:
      return {180, 119, 31};
    case CellOutcome::kInversion:
      return {14, 127, 255};
    case CellOutcome::kBlowUp:
      return {40, 39, 214};
  }
  return {0, 0, 0};
}

void Text(cv::Mat& canvas, const std::string& text, cv::Point at, double scale = 0.4,
          cv::Scalar ink = {40, 40, 40}) {
  cv::putText(canvas, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, ink, 1, cv::LINE_AA);
}

// Rows: motion x guard; columns: dt; each panel E (x, left to right) by nu (y, top to bottom).
void WriteHeatMap(const StabilityResult& result, const Axes& axes, const std::string& png_path) {
  std::map<CellKey, const CellResult*> by_key;
  for (const CellResult& c : result.cells) by_key[KeyOf(c.spec)] = &c;
  const int cell_w = 34, cell_h = 20;
  const int panel_w = cell_w * static_cast<int>(axes.youngs.size());
  const int panel_h = cell_h * static_cast<int>(axes.poissons.size());
  const int gap_x = 50, gap_y = 34, left = 190, top = 90, legend_h = 60;
  const int rows = static_cast<int>(axes.motions.size() * axes.guards.size());
  const int columns = static_cast<int>(axes.dts.size());
  const int width = std::max(left + columns * (panel_w + gap_x), 1100);
  cv::Mat canvas(top + rows * (panel_h + gap_y) + legend_h, width, CV_8UC3, cv::Scalar(255, 255, 255));
  Text(canvas, "dynaguide eval stability: the outcome of each cell", {10, 22}, 0.6);
  Text(canvas, "a panel per time step: Young's modulus E (Pa) across, Poisson's ratio nu down; xN: N substeps per step",
       {10, 46}, 0.45);
  for (int col = 0; col < columns; ++col) {
    Text(canvas, "dt = " + Ms(axes.dts[col]) + " ms", {left + col * (panel_w + gap_x) + panel_w / 2 - 40, top - 28},
         0.5);
  }
  int row = 0;
  for (const std::string& motion : axes.motions) {
    for (Guard guard : axes.guards) {
      const int y0 = top + row * (panel_h + gap_y);
      Text(canvas, motion, {10, y0 + panel_h / 2 - 4}, 0.45);
      Text(canvas, "guard " + GuardName(guard), {10, y0 + panel_h / 2 + 14}, 0.45);
      for (int col = 0; col < columns; ++col) {
        const int x0 = left + col * (panel_w + gap_x);
        for (size_t e = 0; e < axes.youngs.size(); ++e) {
          for (size_t n = 0; n < axes.poissons.size(); ++n) {
            const cv::Rect box(x0 + static_cast<int>(e) * cell_w, y0 + static_cast<int>(n) * cell_h, cell_w, cell_h);
            const auto found =
                by_key.find({motion, static_cast<int>(guard), axes.youngs[e], axes.poissons[n], axes.dts[col]});
            if (found == by_key.end()) {  // not run (yet): hatched white
              cv::line(canvas, box.tl(), box.br(), {200, 200, 200}, 1);
              continue;
            }
            const CellResult& c = *found->second;
            cv::rectangle(canvas, box, OutcomeColour(c.outcome), cv::FILLED);
            if (c.outcome == CellOutcome::kSubstepped) {
              Text(canvas, Printed("x%d", c.substeps), box.tl() + cv::Point(3, 14), 0.33, {255, 255, 255});
            }
            cv::rectangle(canvas, box, {255, 255, 255}, 1);
          }
        }
        // Axis labels: E under every panel, nu left of the first column's.
        for (size_t e = 0; e < axes.youngs.size(); ++e) {
          Text(canvas, Modulus(axes.youngs[e]), {x0 + static_cast<int>(e) * cell_w + 3, y0 + panel_h + 12}, 0.3);
        }
        if (col == 0) {
          for (size_t n = 0; n < axes.poissons.size(); ++n) {
            char nu[16];
            std::snprintf(nu, sizeof nu, "%g", axes.poissons[n]);
            Text(canvas, nu, {x0 - 38, y0 + static_cast<int>(n) * cell_h + 14}, 0.33);
          }
        }
      }
      ++row;
    }
  }
  // Legend.
  int x = 10;
  const int y = canvas.rows - legend_h / 2;
  for (CellOutcome outcome : AllOutcomes()) {
    cv::rectangle(canvas, cv::Rect(x, y - 12, 24, 16), OutcomeColour(outcome), cv::FILLED);
    Text(canvas, OutcomeName(outcome), {x + 30, y + 1}, 0.5);
    x += 150;
  }
  if (!cv::imwrite(png_path, canvas)) {
    throw Error("cannot write the heat map", png_path, "check the directory is writable");
  }
}

std::string CsvQuoted(const std::string& text) {
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string CellsCsv(const std::vector<CellResult>& cells) {
  std::string csv =
      "cell,motion,guard,youngs_modulus_pa,poissons_ratio,dt_ms,outcome,detector,dt_critical_ms,"
      "dt_element_bound_ms,substeps,internal_steps,simulated_s,wall_s,max_prescribed_mm,map_deviation_ratio,"
      "final_ratio,min_jacobian,nodes,tets,message\n";
  for (const CellResult& c : cells) {
    csv += Printed("%s,%s,%s,%.10g,%.10g,%.10g,%s,%s,%.10g,%.10g,%d,%lld,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%d,%d,",
                   c.spec.Name().c_str(), c.spec.motion.c_str(), GuardName(c.spec.guard).c_str(),
                   c.spec.youngs_modulus_pa, c.spec.poissons_ratio, c.spec.dt_s * 1e3, OutcomeName(c.outcome).c_str(),
                   c.detector.c_str(), c.dt_critical_s * 1e3, c.dt_element_bound_s * 1e3, c.substeps,
                   c.internal_steps, c.simulated_s, c.wall_s, c.max_prescribed_mm, c.map_deviation_ratio,
                   c.final_ratio, c.min_jacobian, c.nodes, c.tets) +
           CsvQuoted(c.message) + "\n";
  }
  return csv;
}

std::string BisectionCsv(const std::vector<BisectionResult>& bisections) {
  std::string csv =
      "case,youngs_modulus_pa,poissons_ratio,motion,dt_critical_ms,dt_element_bound_ms,dt_stable_ms,dt_unstable_ms,"
      "limit_ms,limit_over_dt_critical,limit_over_element_bound,trials,trial_steps\n";
  for (const BisectionResult& b : bisections) {
    const BisectionCase& c = b.bisection_case;
    csv += Printed("%s,%.10g,%.10g,%s,%.10g,%.10g,%.10g,%.10g,%.10g,%.6f,%.6f,%zu,%lld\n", c.Name().c_str(),
                   c.youngs_modulus_pa, c.poissons_ratio, c.motion.c_str(), b.dt_critical_s * 1e3,
                   b.dt_element_bound_s * 1e3, b.dt_stable_s * 1e3, b.dt_unstable_s * 1e3, b.limit_s() * 1e3,
                   b.ratio_to_estimate(), b.ratio_to_element_bound(), b.trial_dt_s.size(), b.trial_steps);
  }
  return csv;
}

std::string CountsTable(const std::vector<CellResult>& cells, const Axes& axes) {
  std::string md = "| motion | guard |";
  for (CellOutcome o : AllOutcomes()) md += Printed(" %s |", OutcomeName(o).c_str());
  md += " cells | wall (s) |\n|---|---|";
  for (size_t k = 0; k <= AllOutcomes().size() + 1; ++k) md += "---:|";
  md += "\n";
  std::map<CellOutcome, int> total;
  double total_wall = 0;
  for (const std::string& motion : axes.motions) {
    for (Guard guard : axes.guards) {
      std::map<CellOutcome, int> count;
      int n = 0;
      double wall = 0;
      for (const CellResult& c : cells) {
        if (c.spec.motion != motion || c.spec.guard != guard) continue;
        ++count[c.outcome];
        ++total[c.outcome];
        ++n;
        wall += c.wall_s;
      }
      total_wall += wall;
      md += "| " + motion + " | " + GuardName(guard) + " |";
      for (CellOutcome o : AllOutcomes()) md += Printed(" %d |", count[o]);
      md += Printed(" %d | %.1f |\n", n, wall);
    }
  }
  md += "| **all** | |";
  for (CellOutcome o : AllOutcomes()) md += " **" + std::to_string(total[o]) + "** |";
  md += " **" + std::to_string(cells.size()) + "** | " + Printed("%.1f", total_wall) + " |\n";
  return md;
}

// Each material's limits (they do not depend on dt, motion or guard).
std::string LimitsTable(const std::vector<CellResult>& cells) {
  std::map<std::pair<double, double>, const CellResult*> first;
  for (const CellResult& c : cells) first.emplace(std::pair(c.spec.youngs_modulus_pa, c.spec.poissons_ratio), &c);
  std::string md = "| E (Pa) | nu | dt_cr, assembled (ms) | per-element bound (ms) | bound / dt_cr | "
                   "guard's largest dt, 0.9 dt_cr (ms) |\n|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [material, c] : first) {
    md += "| " + Modulus(material.first) + " | " + Printed("%g", material.second) + " | " + Ms(c->dt_critical_s) +
          " | " + Ms(c->dt_element_bound_s) + " | " + Printed("%.2f", c->dt_element_bound_s / c->dt_critical_s) +
          " | " + Ms(0.9 * c->dt_critical_s) + " |\n";
  }
  return md;
}

std::string BisectionTable(const std::vector<BisectionResult>& bisections) {
  std::string md = "| case | dt_cr, assembled (ms) | per-element bound (ms) | bisected limit (ms) | "
                   "limit / dt_cr | limit / bound | bound conservative | trials x steps |\n"
                   "|---|---:|---:|---:|---:|---:|---|---:|\n";
  for (const BisectionResult& b : bisections) {
    md += "| " + b.bisection_case.Name() + " | " + Ms(b.dt_critical_s, 4) + " | " + Ms(b.dt_element_bound_s, 4) +
          " | " + Ms(b.dt_stable_s, 4) + " to " + Ms(b.dt_unstable_s, 4) + " | " +
          Printed("%.3f", b.ratio_to_estimate()) + " | " + Printed("%.2f", b.ratio_to_element_bound()) + " | " +
          (b.dt_element_bound_s <= b.dt_stable_s ? "yes" : "**no**") + " | " +
          std::to_string(b.trial_dt_s.size()) + " x " + std::to_string(b.trial_steps) + " |\n";
  }
  return md;
}

// Per motion and guard: rows E x nu, columns dt.
std::string CellTables(const std::vector<CellResult>& cells, const Axes& axes) {
  std::map<CellKey, const CellResult*> by_key;
  for (const CellResult& c : cells) by_key[KeyOf(c.spec)] = &c;
  std::string md;
  for (const std::string& motion : axes.motions) {
    for (Guard guard : axes.guards) {
      md += "### " + motion + " motion, guard " + GuardName(guard) + "\n\n| E (Pa) | nu |";
      for (double dt : axes.dts) md += Printed(" %s ms |", Ms(dt).c_str());
      md += "\n|---:|---:|";
      for (size_t k = 0; k < axes.dts.size(); ++k) md += "---|";
      md += "\n";
      for (double E : axes.youngs) {
        for (double nu : axes.poissons) {
          md += "| " + Modulus(E) + " | " + Printed("%g", nu) + " |";
          for (double dt : axes.dts) {
            const auto found = by_key.find({motion, static_cast<int>(guard), E, nu, dt});
            md += found == by_key.end() ? std::string(" - |") : Printed(" %s |", Short(*found->second).c_str());
          }
          md += "\n";
        }
      }
      md += "\n";
    }
  }
  return md;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw Error("cannot write the report", path, "check the directory is writable");
}

}  // namespace

std::string WriteStabilityReport(const StabilityResult& result, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  const Axes axes = AxesOf(result.cells);
  const CellResult& any = result.cells.front();
  std::string md = "# dynaguide eval stability\n\n";
  md += Printed(
      "%zu cells on the phantom's tissue meshed with %d nodes and %d tetrahedra (float, damping 75 /s, guard "
      "safety 0.9): the base fixed, the curved surface above the centre driven by the motion, one nominal cycle "
      "each. Every figure here is read from the cell logs (cells/*.h5, bisection/*.h5).\n\n",
      result.cells.size(), any.nodes, any.tets);
  for (const CellResult& c : result.cells) {
    if (c.nodes != any.nodes || c.tets != any.tets) {
      md += "**Warning: the logs come from different meshes** (e.g. " + c.spec.Name() + ": " +
            std::to_string(c.tets) + " tets): re-run them with one --tets.\n\n";
      break;
    }
  }
  md += "## Outcomes\n\n" + CountsTable(result.cells, axes) + "\n";
  md += "Stable: ran the cycle with one step per dt, final state finite and plausible. Refused: the guard refused "
        "dt above 0.9 dt_cr. Substepped (xN): the guard split each step into N, then as stable. Inversion: an "
        "element reached J <= 0. Blow-up: kinetic-energy growth or a non-finite value (the solver), or (study) a "
        "free node more than " + Printed("%g", kMaxMapDeviationRatio) + " x the largest prescribed displacement "
        "off the motion's map (also when an element inverts: the inversion is then the blow-up's symptom), or not "
        "back within " + Printed("%g", 100 * kMaxFinalRatio) + "% of it at the cycle's end, where the motion is "
        "back at rest.\n\n";
  md += "## Limits per material\n\n" + LimitsTable(result.cells) + "\n";
  if (!result.bisections.empty()) {
    md += "## True limit by bisection (guard off)\n\n" + BisectionTable(result.bisections) +
          "\nLimit: the bracket [largest stable, smallest unstable] dt of the trials; limit / dt_cr is its middle over "
          "the guard's assembled estimate.\n\n";
  }
  md += "## Cells\n\nHeat map: stability_heatmap.png. Per cell: stable, refused, xN (substepped), inversion, "
        "blow-up.\n\n" + CellTables(result.cells, axes);

  WriteText(out_dir + "/stability.md", md);
  WriteText(out_dir + "/stability.csv", CellsCsv(result.cells));
  WriteText(out_dir + "/bisection.csv", BisectionCsv(result.bisections));
  WriteHeatMap(result, axes, out_dir + "/stability_heatmap.png");
  return md;
}

void WriteStabilityJson(const StabilityResult& result, const std::string& path) {
  using Json = nlohmann::ordered_json;
  Json cells = Json::array();
  for (const CellResult& c : result.cells) {
    cells.push_back({{"cell", c.spec.Name()},
                     {"motion", c.spec.motion},
                     {"guard", GuardName(c.spec.guard)},
                     {"youngs_modulus_pa", Significant(c.spec.youngs_modulus_pa, 10)},
                     {"poissons_ratio", Significant(c.spec.poissons_ratio, 10)},
                     {"dt_ms", Significant(c.spec.dt_s * 1e3, 10)},
                     {"outcome", OutcomeName(c.outcome)},
                     {"detector", c.detector},
                     {"dt_critical_ms", Significant(c.dt_critical_s * 1e3, 10)},
                     {"dt_element_bound_ms", Significant(c.dt_element_bound_s * 1e3, 10)},
                     {"substeps", c.substeps},
                     {"internal_steps", c.internal_steps},
                     {"wall_s", Significant(c.wall_s, 6)}});
  }
  Json bisections = Json::array();
  for (const BisectionResult& b : result.bisections) {
    bisections.push_back({{"case", b.bisection_case.Name()},
                          {"dt_critical_ms", Significant(b.dt_critical_s * 1e3, 10)},
                          {"dt_element_bound_ms", Significant(b.dt_element_bound_s * 1e3, 10)},
                          {"limit_ms", Significant(b.limit_s() * 1e3, 10)},
                          {"limit_over_dt_critical", Decimals(b.ratio_to_estimate(), 6)},
                          {"limit_over_element_bound", Decimals(b.ratio_to_element_bound(), 6)}});
  }
  const Json json = {{"cells", cells}, {"bisections", bisections}};
  WriteText(path, JsonText(json));
}

}  // namespace dg::tools
