#include "tools/preop/preop_job.h"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "io/ct/ct_reader.h"
#include "io/gmsh_mesher.h"
#include "io/h5_file.h"
#include "io/metaimage.h"
#include "io/scene.h"
#include "io/surface_mesh.h"
#include "stages/preop/segment/label_image_writer.h"
#include "sim/error.h"
#include "sim/log.h"
#include "sim/stability.h"
#include "stages/register/bead_detection.h"
#include "stages/register/fiducial_motion.h"
#include "tools/preop/fiducial_file.h"
#include "tools/preop/like_scene.h"
#include "tools/preop/preop_report.h"
#include "tools/preop/registration_cache.h"
#include "tools/preop/surface_uvs.h"

namespace dg::tools::preop {
namespace fs = std::filesystem;
namespace {

// Every phase registered to the first, options.threads at once (each
// registration is single-threaded and independent of the others), with a
// progress line per phase as it finishes. Each is kept in the cache as it
// finishes; with options.resume, those the cache holds are taken from it.
// Result 0 is the identity.
std::vector<stages::preop::PhaseDeformation> RegisterPhasesAtOnce(const std::vector<io::CtImage>& phases,
                                                                  const PreopOptions& options,
                                                                  const stages::preop::MotionRegistrationOptions& motion,
                                                                  int* from_cache) {
  stages::preop::CheckPhases(phases);
  const RegistrationCache cache(options.out_dir + "/cache", phases, motion);
  std::vector<stages::preop::PhaseDeformation> deformations(phases.size());
  std::vector<int> to_register;
  for (int k = 1; k < static_cast<int>(phases.size()); ++k) {
    std::optional<stages::preop::PhaseDeformation> kept = options.resume ? cache.Load(k) : std::nullopt;
    if (kept) {
      deformations[k] = *kept;
    } else {
      to_register.push_back(k);
    }
  }
  *from_cache = static_cast<int>(phases.size()) - 1 - static_cast<int>(to_register.size());
  if (options.progress && *from_cache > 0) {
    std::fprintf(stderr, "preop:   %d phases taken from %s/cache (--resume)\n", *from_cache, options.out_dir.c_str());
  }
  if (to_register.empty()) return deformations;
  const stages::preop::PhaseRegistration registration(phases, motion);
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency());
  arena.execute([&] {
    tbb::parallel_for(0, static_cast<int>(to_register.size()), [&](int i) {
      const int k = to_register[i];
      deformations[k] = registration.Register(k);
      cache.Save(k, deformations[k]);
      if (!options.progress) return;
      const stages::preop::PhaseRegistrationReport& phase = deformations[k].report();
      // One call per line: stdio locks stderr for the call, so lines from phases finishing together never interleave.
      std::fprintf(stderr, "preop:   phase %d registered in %.1f s (metric %.4g -> %.4g, Jacobian %.3f..%.3f)\n",
                   phase.phase, phase.wall_s, phase.metric_before, phase.metric_after, phase.min_jacobian,
                   phase.max_jacobian);
    });
  });
  return deformations;
}

// The material and time step the scene will be simulated with: the like
// scene's, else the defaults.
std::pair<sim::Material, double> SceneMaterialAndStep(const std::string& like_scene) {
  if (like_scene.empty()) return {sim::Material{}, io::Scene::Simulation{}.dt_s};
  const io::Scene like = io::ReadScene(like_scene);
  return {like.material, like.simulation ? like.simulation->dt_s : io::Scene::Simulation{}.dt_s};
}

// The organ as a solid the mesher takes, with its surface: the segmented
// mask when its surface is the boundary of one solid ball, else the mask
// closed by a larger ball in turn (kTunnelClosings_mm), which fills the
// tunnels vessels make through an organ (docs/preop.md, "Surface."). The
// radius used is kept (0: none).
struct SolidAndSurface {
  stages::preop::VoxelMask organ;
  io::SurfaceMesh surface;
};
SolidAndSurface SolidOrgan(const stages::preop::VoxelMask& segmented, const stages::preop::SurfaceOptions& options,
                           stages::preop::SurfaceReport* report, double* closing_mm) {
  *closing_mm = 0;
  try {
    return {segmented, stages::preop::ExtractSurface(segmented, options, report)};
  } catch (const stages::preop::NotASolidBall& as_segmented) {
    std::string closings;
    for (const double radius_mm : kTunnelClosings_mm) {
      stages::preop::VoxelMask closed = stages::preop::ClosedSolid(segmented, radius_mm);
      io::SurfaceMesh surface;
      try {
        surface = stages::preop::ExtractSurface(closed, options, report);
      } catch (const stages::preop::NotASolidBall& e) {
        const std::string& attempts = e.problem();  // its last line: the most blurred attempt
        closings += fmt::format("\n  closed by {:g} mm, then{}", radius_mm, attempts.substr(attempts.rfind('\n') + 2));
        continue;
      }
      Logger("tools").warn("the organ's mask is not one solid ball (tunnels, or pieces the blur joins); closed by a "
                           "ball of {:g} mm, which adds {:.1f} ml to its {:.1f} ml",
                           radius_mm, 1e6 * (closed.Volume_m3() - segmented.Volume_m3()), 1e6 * segmented.Volume_m3());
      *closing_mm = radius_mm;
      return {std::move(closed), std::move(surface)};
    }
    throw stages::preop::NotASolidBall(
        as_segmented.problem() + "\nnor after closing the mask to fill tunnels:" + closings, as_segmented.where(),
        fmt::format("the mask holds pieces or tunnels wider than {:g} mm (a label that takes in neighbouring "
                    "organs?): check it in 3D Slicer (segmentation.nii.gz), restrict it (--roi, --seed-point), or "
                    "fill them in the label map",
                    kTunnelClosings_mm[std::size(kTunnelClosings_mm) - 1]));
  }
}

double PeakRssGb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / (1024.0 * 1024.0);  // ru_maxrss is in KiB on Linux
}

using Clock = std::chrono::steady_clock;

// Fewer beads than this are not fiducials: the registration's rigid pose
// needs three.
constexpr size_t kMinBeads = 3;

// A bead farther than this from a like scene's fiducial is not that fiducial.
constexpr double kMaxFiducialMatch_m = 3e-3;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The volume overlay and bead detection read axis-aligned MetaImages.
io::VolumeI16 ToAxisAlignedVolume(const io::CtImage& ct) {
  if (!ct.direction.isIdentity(1e-9)) {
    throw Error("the CT's voxel axes are not the scan frame's (direction cosines are not the identity)", ct.source,
                "resample the CT to an axis-aligned grid (e.g. 3D Slicer's Resample Scalar Volume, or ITK's "
                "ResampleImageFilter) before dynaguide preop");
  }
  io::VolumeI16 volume;
  volume.size = ct.size;
  volume.spacing_m = ct.spacing_m;
  volume.origin_m = ct.origin_m;
  volume.values.resize(ct.values.size());
  for (size_t v = 0; v < ct.values.size(); ++v) {
    volume.values[v] = static_cast<std::int16_t>(std::lround(std::clamp(ct.values[v], -32768.f, 32767.f)));
  }
  return volume;
}

// The registration pairs the scan's fiducial i with the video's fiducial i,
// so beads found in the CT (in the order found) take the order of the like
// scene's scan: each is matched to the nearest of its phase-0 fiducials. Only
// the order is taken; the positions stay the found ones.
void OrderLikeScene(const std::string& like_scene, stages::FiducialMotion* found) {
  const io::Scene like = io::ReadScene(like_scene);
  if (!like.preoperative) return;
  const Eigen::Matrix3Xd reference = stages::ReadFiducialMotion(like.preoperative->motion).positions_S_m.front();
  const Eigen::Matrix3Xd& first = found->positions_S_m.front();
  if (reference.cols() != first.cols()) {
    throw Error("the CT has " + std::to_string(first.cols()) + " beads, the like scene's scan " +
                    std::to_string(reference.cols()) + " fiducials",
                like.preoperative->motion, "use a like scene recorded with the same markers");
  }
  std::vector<Eigen::Index> order(reference.cols());
  std::vector<bool> taken(first.cols(), false);
  for (Eigen::Index i = 0; i < reference.cols(); ++i) {
    const double distance = (first.colwise() - reference.col(i)).colwise().norm().minCoeff(&order[i]);
    if (taken[order[i]] || distance > kMaxFiducialMatch_m) {
      throw Error("fiducial " + std::to_string(i) + " of the like scene has no bead of its own within " +
                      std::to_string(1e3 * kMaxFiducialMatch_m) + " mm in the CT (nearest " +
                      std::to_string(1e3 * distance) + " mm)",
                  like.preoperative->motion, "use a like scene in the CT's frame, with the same markers");
    }
    taken[order[i]] = true;
  }
  for (Eigen::Matrix3Xd& phase : found->positions_S_m) phase = Eigen::Matrix3Xd(phase(Eigen::all, order));
}

class Steps {
 public:
  Steps(PreopSummary* summary, bool progress) : summary_(summary), progress_(progress) {}
  template <typename Body>
  auto Run(const std::string& name, Body&& body) {
    if (progress_) std::fprintf(stderr, "preop: %s\n", name.c_str());
    const Clock::time_point start = Clock::now();
    if constexpr (std::is_void_v<decltype(body())>) {
      body();
      summary_->steps.push_back({name, SecondsSince(start)});
    } else {
      auto result = body();
      summary_->steps.push_back({name, SecondsSince(start)});
      return result;
    }
  }

 private:
  PreopSummary* summary_;
  bool progress_;
};

}  // namespace

std::string PreopOptions::Validate() const {
  if (ct_inputs.empty()) return "give the CT: a DICOM folder of every phase, a folder per phase or a file per phase";
  if (out_dir.empty()) return "give --out";
  if (!(period_s > 0) && like_scene.empty()) {
    return "give the CT's cycle in seconds, a heartbeat or a breath (--period-s), or a scene to take it from (--like)";
  }
  if (period_s < 0) return "the period must be positive";
  if (threads < 0) return "threads must be 0 (TBB's default) or more, got " + std::to_string(threads);
  for (const std::string& problem :
       {segmentation.Validate(), surface.Validate(), mesh.Validate(), motion.Validate(), beads.Validate()}) {
    if (!problem.empty()) return problem;
  }
  return {};
}

std::string PreopSummary::Describe() const {
  std::ostringstream text;
  char line[256];
  std::snprintf(line, sizeof line, "CT: %d phases of %d x %d x %d voxels (%.3g x %.3g x %.3g mm)\n", phases,
                ct_size.x(), ct_size.y(), ct_size.z(), 1e3 * ct_spacing_m.x(), 1e3 * ct_spacing_m.y(),
                1e3 * ct_spacing_m.z());
  text << line;
  if (!ct_reoriented_from.empty()) text << "  put on the scan frame's axes from " << ct_reoriented_from << "\n";
  text << "segmentation: " << segmentation.Describe() << "\n";
  std::snprintf(line, sizeof line, "mesh: %d nodes, %d tetrahedra, worst radius ratio %.3f, %d base nodes\n",
                mesh.nodes, mesh.tets, mesh.min_radius_ratio, mesh.base_nodes);
  text << line;
  double worst_jacobian = 1;
  for (const auto& phase : registration) worst_jacobian = std::min(worst_jacobian, phase.min_jacobian);
  std::snprintf(line, sizeof line, "motion: %zu phases registered, smallest Jacobian %.3f\n",
                registration.empty() ? 0 : registration.size() - 1, worst_jacobian);
  text << line;
  std::snprintf(line, sizeof line, "stability: critical time step %.4g ms, the scene's %.4g ms within %.2f of it\n",
                1e3 * stability.dt_critical_s, 1e3 * stability.dt_s, stability.safety);
  text << line;
  if (phases_from_cache > 0) text << "  " << phases_from_cache << " phases' registrations taken from the cache\n";
  if (fiducial_source == FiducialSource::kNone) {
    text << "fiducials: none found; give them with --fiducials FILE before `dynaguide run`\n";
  } else if (fiducial_source == FiducialSource::kFile) {
    text << "fiducials: " << fiducial_count << " from the file, moved by the registration\n";
  } else {
    std::snprintf(line, sizeof line, "fiducials: %d beads, deformed against found %.3f mm on average, %.3f mm at most\n",
                  fiducial_count, 1e3 * fiducials.mean_m(), 1e3 * fiducials.error_m.maxCoeff());
    text << line;
  }
  for (const StepTime& step : steps) {
    std::snprintf(line, sizeof line, "  %-28s %7.2f s\n", step.step.c_str(), step.wall_s);
    text << line;
  }
  std::snprintf(line, sizeof line, "preop: %.1f s, peak memory %.2f GB\n", wall_s, peak_rss_gb);
  text << line;
  return text.str();
}

MeshStability EstimateMeshStability(const sim::TetMesh& mesh, const sim::Material& material, double dt_s) {
  std::vector<int> fixed_dofs;
  if (const auto base = mesh.node_sets.find("base"); base != mesh.node_sets.end()) {
    for (int a : base->second) {
      for (int i = 0; i < 3; ++i) fixed_dofs.push_back(3 * a + i);
    }
  }
  const sim::StabilityReport report = sim::EstimateStability(mesh, material, fixed_dofs);
  const double safety = sim::DefaultStabilitySafety(material.poissons_ratio);
  return {.dt_critical_s = report.dt_critical_s,
          .dt_s = dt_s,
          .safety = safety,
          .limit = report.Describe(),
          .excess = report.TimeStepExcess(dt_s, safety)};
}

sim::TetMesh MeshForScene(const io::SurfaceMesh& surface, const stages::preop::VoxelMask& mount,
                          stages::preop::TetrahedralisationOptions options, const sim::Material& material, double dt_s,
                          stages::preop::TetrahedralisationReport* report, MeshStability* stability) {
  sim::TetMesh mesh = stages::preop::Tetrahedralise(surface, mount, options, report);
  *stability = EstimateMeshStability(mesh, material, dt_s);
  for (int attempt = 0; attempt < kStabilityRemeshings && !stability->excess.empty(); ++attempt) {
    // The stable step scales with the elements' size, size with count^(-1/3).
    const double short_by = dt_s / (stability->safety * stability->dt_critical_s);
    options.target_tets = static_cast<int>(options.target_tets * std::min(0.9, std::pow(short_by, -3.0)));
    Logger("tools").info("the mesh of {} tetrahedra allows steps of {:.3f} ms, under the scene's {:.3f} ms: meshing "
                         "again at {} tetrahedra",
                         mesh.num_tets(), 1e3 * stability->safety * stability->dt_critical_s, 1e3 * dt_s,
                         options.target_tets);
    stages::preop::TetrahedralisationReport coarser_report;
    sim::TetMesh coarser = stages::preop::Tetrahedralise(surface, mount, options, &coarser_report);
    const MeshStability coarser_stability = EstimateMeshStability(coarser, material, dt_s);
    if (coarser_stability.dt_critical_s > stability->dt_critical_s) {  // else keep the better one, and go coarser
      mesh = std::move(coarser);
      *report = coarser_report;
      *stability = coarser_stability;
    }
  }
  return mesh;
}

PreopSummary RunPreop(const PreopOptions& options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error("invalid preop options: " + problem, "dynaguide preop", "correct the option");
  }
  const Clock::time_point start = Clock::now();
  const std::string& out = options.out_dir;
  for (const char* sub : {"", "/ct", "/assets"}) fs::create_directories(out + sub);
  PreopSummary summary;
  PreopReportFile report(out + "/preop.json", options);  // marked incomplete until Complete()
  try {
    Steps steps(&summary, options.progress);

    io::CtReadOptions reading;
    reading.series_uids = options.series_uids;
    reading.intensity = options.intensity;
    reading.intensity_slope = options.intensity_slope;
    reading.intensity_intercept = options.intensity_intercept;
    reading.progress = [&](const io::CtImage& phase, int index, int count) {
      if (options.progress) std::fprintf(stderr, "preop:   phase %d of %d: %s\n", index + 1, count, phase.source.c_str());
    };
    const std::vector<io::CtImage> phases =
        steps.Run("reading the CT", [&] { return io::ReadCtPhases(options.ct_inputs, reading); });
    summary.phases = static_cast<int>(phases.size());
    summary.ct_size = phases.front().size;
    summary.ct_spacing_m = phases.front().spacing_m;
    summary.ct_reoriented_from = phases.front().reoriented_from;
    if (phases.size() < 2) {
      throw Error("the CT has one phase", options.ct_inputs.front(),
                  "give every phase of the 4D CT (a series per phase, or a file per phase)");
    }

    std::vector<std::string> ct_files;
    steps.Run("writing the phases as MetaImage", [&] {
      for (size_t k = 0; k < phases.size(); ++k) {
        char name[64];
        std::snprintf(name, sizeof name, "ct/phase_%02zu.mhd", k);
        io::WriteMetaImage(out + "/" + name, ToAxisAlignedVolume(phases[k]));
        ct_files.push_back(out + "/" + name);
      }
    });

    const stages::preop::Segmentation segmentation = steps.Run("segmentation", [&] {
      if (options.label_map.empty()) return stages::preop::Segment(phases.front(), options.segmentation);
      return stages::preop::Segment(phases.front(), io::ReadLabelMap(options.label_map), options.segmentation);
    });
    summary.segmentation = segmentation.report;
    steps.Run("writing the segmentation", [&] { stages::preop::WriteLabelImage(segmentation, out + "/segmentation.nii.gz"); });

    // The surface's smoothing and the mesh are one step: a closed manifold
    // surface can still cut itself or carry detail finer than the elements,
    // which only Gmsh finds; it is then extracted again from a smoother mask.
    io::SurfaceMesh surface;
    const sim::TetMesh mesh = steps.Run("surface and tetrahedralisation", [&] {
      const auto [material, dt_s] = SceneMaterialAndStep(options.like_scene);
      stages::preop::SurfaceOptions smoothing = options.surface;
      SolidAndSurface solid =
          SolidOrgan(segmentation.organ, smoothing, &summary.surface, &summary.tunnel_closing_mm);
      surface = std::move(solid.surface);
      for (size_t attempt = 0;; ++attempt) {
        if (attempt > 0) surface = stages::preop::ExtractSurface(solid.organ, smoothing, &summary.surface);
        try {
          sim::TetMesh tets = MeshForScene(surface, segmentation.mount, options.mesh, material, dt_s, &summary.mesh,
                                           &summary.stability);
          tets.source = out + "/mesh.msh";
          return tets;
        } catch (const stages::preop::UnmeshableSurface& e) {
          if (attempt == std::size(kExtraSmoothingVoxels)) throw;
          smoothing.image_smoothing_sigma_voxels =
              summary.surface.image_smoothing_sigma_voxels + kExtraSmoothingVoxels[attempt];
          Logger("tools").warn("{}; extracting the surface again from the mask blurred by {:g} voxels", e.problem(),
                               smoothing.image_smoothing_sigma_voxels);
        }
      }
    });
    if (!summary.stability.excess.empty()) {
      if (!options.like_scene.empty()) {
        throw Error("the mesh is not stable at the scene's time step: " + summary.stability.excess, mesh.source,
                    "mesh with fewer tetrahedra (--tets) or a smoother surface (--triangles, --smoothing-voxels), so "
                    "that no element is much smaller than the rest; `dynaguide run` would refuse this scene");
      }
      Logger("tools").warn("the mesh needs a smaller time step than the default: {}", summary.stability.excess);
    }
    steps.Run("writing the mesh", [&] { io::WriteMsh(mesh, mesh.source, 41); });
    if (summary.mesh.base_nodes == 0) {
      Logger("tools").warn("no mesh node touches the mount: the simulation has no fixed nodes and needs its "
                           "surface constraints to hold the organ (check the mount's HU range or label)");
    }

    // The fiducials before the registrations: a wrong bead count is found in
    // seconds, not after every phase is registered.
    stages::FiducialMotion beads;
    steps.Run("fiducials", [&] {
      if (!options.fiducials_file.empty()) {
        beads.positions_S_m.assign(phases.size(), ReadFiducialFile(options.fiducials_file));
        summary.fiducial_source = FiducialSource::kFile;
      } else {
        const std::vector<std::vector<Eigen::Vector3d>> found = stages::DetectBeadsInPhases(ct_files, options.beads);
        if (!found.front().empty() && found.front().size() < kMinBeads) {
          // Too few to register with (a rigid pose needs three): not markers but bone, calcium or metal.
          std::string where;
          for (const Eigen::Vector3d& bead : found.front()) where += fmt::format(" ({:.1f}, {:.1f}, {:.1f})", 1e3 * bead.x(), 1e3 * bead.y(), 1e3 * bead.z());
          Logger("tools").warn("{} bead-like objects {} at{} mm: fewer than the {} a registration needs, so not taken "
                               "as fiducials",
                               found.front().size(), options.beads.Describe(), where, kMinBeads);
          beads = stages::MatchBeadsAcrossPhases(std::vector<std::vector<Eigen::Vector3d>>(found.size()), ct_files,
                                                 options.beads);  // none
          return;
        }
        beads = stages::MatchBeadsAcrossPhases(found, ct_files, options.beads);
        summary.fiducial_source = found.front().empty() ? FiducialSource::kNone : FiducialSource::kBeads;
      }
      if (!options.like_scene.empty() && summary.fiducial_source != FiducialSource::kNone) {
        OrderLikeScene(options.like_scene, &beads);
      }
      summary.fiducial_count = beads.num_fiducials();
    });
    if (summary.fiducial_source == FiducialSource::kNone) {
      Logger("tools").warn("no fiducial bead {} in the CT: the scan gets mesh, motion and assets but no fiducials; "
                           "the registration to the video needs them: run preop again with --fiducials FILE "
                           "(3D Slicer markups, phase 0) and --resume",
                           options.beads.Describe());
    }

    // The motion is wanted at the mesh's nodes and the fiducials only: on
    // request the registration works on their box (and a margin), not the
    // whole scan.
    stages::preop::MotionRegistrationOptions motion = options.motion;
    if (options.register_organ_box) {
      Eigen::AlignedBox3d wanted;
      for (Eigen::Index n = 0; n < mesh.X_m.cols(); ++n) wanted.extend(mesh.X_m.col(n));
      if (beads.num_fiducials() > 0) {
        for (Eigen::Index f = 0; f < beads.positions_S_m[0].cols(); ++f) wanted.extend(beads.positions_S_m[0].col(f));
      }
      motion.region_min_S_m = wanted.min();
      motion.region_max_S_m = wanted.max();
    }
    const std::vector<stages::preop::PhaseDeformation> deformations = steps.Run("B-spline motion", [&] {
      return RegisterPhasesAtOnce(phases, options, motion, &summary.phases_from_cache);
    });
    for (const auto& deformation : deformations) summary.registration.push_back(deformation.report());

    const int P = summary.phases, F = beads.num_fiducials(), N = mesh.num_nodes();
    std::vector<Eigen::Matrix3Xd> deformed(P);
    for (int k = 0; k < P; ++k) {
      deformed[k] = beads.positions_S_m[0] + deformations[k].Displacements(beads.positions_S_m[0]);
    }
    if (summary.fiducial_source == FiducialSource::kFile) {
      beads.positions_S_m = deformed;  // marked once: they move as the registration says
    } else if (summary.fiducial_source == FiducialSource::kBeads) {
      summary.fiducials.error_m.resize(P, F);
      for (int k = 0; k < P; ++k) summary.fiducials.error_m.row(k) = (deformed[k] - beads.positions_S_m[k]).colwise().norm();
    }

    steps.Run("writing scan.h5", [&] {
      const std::vector<double> node_displacement = stages::preop::NodeDisplacementArray(deformations, mesh.X_m);
      std::vector<double> phase_values, found, pushed;
      for (int k = 0; k < P; ++k) {
        phase_values.push_back(double(k) / P);
        if (F == 0) continue;
        found.insert(found.end(), beads.positions_S_m[k].data(), beads.positions_S_m[k].data() + 3 * F);
        pushed.insert(pushed.end(), deformed[k].data(), deformed[k].data() + 3 * F);
      }
      io::H5Writer scan(out + "/scan.h5");
      scan.Write("/phases/phase", phase_values.data(), {size_t(P)});
      scan.Write("/phases/node_displacement_m", node_displacement.data(), {size_t(P), size_t(N), 3});
      if (F > 0) {
        scan.Write("/phases/fiducials_S_m", found.data(), {size_t(P), size_t(F), 3});
        scan.Write("/phases/fiducials_deformed_S_m", pushed.data(), {size_t(P), size_t(F), 3});
        scan.WriteAttribute("/phases/fiducials_S_m", "source",
                            summary.fiducial_source == FiducialSource::kFile ? "file, moved by the registration"
                                                                             : "beads found in each phase");
      }
      scan.Write("/nodes_S_m", mesh.X_m.data(), {size_t(N), 3});
      scan.WriteAttribute("/", "phases", P);
      scan.WriteAttribute("/", "fiducials", F);
      if (options.period_s > 0) scan.WriteAttribute("/", "period_s", options.period_s);
    });

    steps.Run("overlay assets", [&] {
      io::SurfaceMesh organ = surface;
      if (!options.annotation.empty()) {
        const std::string image = "assets/annotation" + fs::path(options.annotation).extension().string();
        fs::copy_file(options.annotation, out + "/" + image, fs::copy_options::overwrite_existing);
        organ.uvs = PlanarUvs(organ);
        io::WriteObj(out + "/assets/surface.obj", organ, {1.0, fs::path(image).filename().string()});
      } else {
        io::WriteObj(out + "/assets/surface.obj", organ);
      }
      stages::preop::SurfaceOptions drawn = options.surface;
      drawn.require_solid_ball = false;  // drawn, not meshed: vessels may branch and loop
      for (size_t s = 0; s < segmentation.internal.size(); ++s) {
        io::WriteObj(out + "/assets/internal_" + std::to_string(s) + ".obj",
                     stages::preop::ExtractSurface(segmentation.internal[s], drawn));
      }
    });

    if (!options.like_scene.empty()) {
      steps.Run("scene.yaml", [&] {
        WriteSceneLike(options.like_scene, out, {.phases = P,
                                                  .period_s = options.period_s,
                                                  .internal_meshes = static_cast<int>(segmentation.internal.size()),
                                                  .texture = !options.annotation.empty(),
                                                  .fiducials = F});
      });
    }
    summary.wall_s = SecondsSince(start);
    summary.peak_rss_gb = PeakRssGb();
    report.Complete(summary);
  } catch (const std::exception& e) {
    summary.wall_s = SecondsSince(start);
    summary.peak_rss_gb = PeakRssGb();
    report.Fail(summary, e.what());
    throw;
  } catch (...) {
    summary.wall_s = SecondsSince(start);
    report.Fail(summary, "an error of a type that is not an exception class (from a library)");
    throw;
  }
  return summary;
}

}  // namespace dg::tools::preop
