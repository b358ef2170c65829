#include "stages/preop/segment/segmentation_presets.h"

#include <fmt/format.h>

#include "sim/error.h"

namespace dg::stages::preop {
namespace {

// What every real scan's preset shares: no mount, no markers, radii in mm
// (a 3 mm opening cuts bridges up to about 6 mm thick between touching
// organs; a 5 mm closing bridges a vessel's notch in the surface), and
// internal structures of at least 1 ml (the smaller are vessels' branches).
SegmentationOptions RealScan(const char* name) {
  SegmentationOptions o;
  o.preset = name;
  o.find_mount = false;
  o.marker_min_hu.reset();
  o.opening_radius_mm = 3.0;
  o.closing_radius_mm = 5.0;
  o.min_internal_volume_m3 = 1e-6;
  return o;
}

// The liver touches the kidney, stomach, diaphragm and bowel over patches
// about a centimetre thick, all of soft tissue's CT numbers: a 6 mm opening
// parts them (on TotalSegmentator's abdominal test CT, 3 mm voxels, the
// liver's Dice against its label rose from 0.72 with 3 mm to 0.92).
constexpr double kAbdominalOpening_mm = 6.0;

}  // namespace

SegmentationOptions PhantomPreset() { return SegmentationOptions{}; }

// Coronary CT angiography: SCCT guidelines (Abbara et al., J Cardiovasc
// Comput Tomogr 2016;10:435) ask for at least 250 HU in the contrast-filled
// lumen, and left-heart blood pools reach 400-600 HU; enhanced myocardium
// lies at about 80-150 HU. Organ = myocardium and blood [50, 700] HU (under
// most cortical bone), internal = blood [250, 700] HU; epicardial fat (about
// -100 HU) is left out, so the heart stays apart from the mediastinum's fat.
SegmentationOptions CardiacContrastPreset() {
  SegmentationOptions o = RealScan("cardiac-contrast");
  o.organ_hu = {50, 700};
  o.internal_hu = {250, 700};
  return o;
}

// Non-contrast chest: blood 30-45 HU and myocardium 40-60 HU (the usual
// tables of the Hounsfield scale) overlap within noise, so the heart is one soft-tissue
// solid [0, 100] HU (water to the densest muscle) without internal structures.
SegmentationOptions ChestPreset() {
  SegmentationOptions o = RealScan("chest");
  o.organ_hu = {0, 100};
  o.max_internal_structures = 0;
  return o;
}

// Non-contrast abdomen: unenhanced liver about 55 HU (40 HU and under in
// steatosis; Kodama et al., AJR 2007;188:1307), spleen 45-50 HU, kidney
// 30 HU, muscle 40-60 HU. Organ = soft tissue [0, 100] HU; the liver's
// vessels (blood 40 HU) are not told apart without contrast.
SegmentationOptions AbdomenPreset() {
  SegmentationOptions o = RealScan("abdomen");
  o.organ_hu = {0, 100};
  o.max_internal_structures = 0;
  o.opening_radius_mm = kAbdominalOpening_mm;
  return o;
}

// Portal venous phase (about 70 s after injection): liver parenchyma
// enhances to about 100-130 HU and the portal and hepatic veins to
// 150-250 HU (Bae, Radiology 2010;256:32). Organ = parenchyma and vessels
// [40, 300] HU, internal = vessels [170, 300] HU.
SegmentationOptions LiverPreset() {
  SegmentationOptions o = RealScan("liver");
  o.organ_hu = {40, 300};
  o.internal_hu = {170, 300};
  o.opening_radius_mm = kAbdominalOpening_mm;
  return o;
}

// Lung parenchyma between -950 HU (under it, emphysema: Gevenois et al., Am
// J Respir Crit Care Med 1996;154:187) and -500 HU (the threshold of lung
// against the chest wall in Hu, Hoffman & Reinhardt, IEEE TMI 2001;20:490).
// Air in the airways and the vessels fall outside and become holes, which
// are filled; each lung is its own component (pick one with a seed point).
SegmentationOptions LungPreset() {
  SegmentationOptions o = RealScan("lung");
  o.organ_hu = {-950, -500};
  o.max_internal_structures = 0;
  return o;
}

std::vector<std::string> SegmentationPresetNames() {
  return {"phantom", "cardiac-contrast", "chest", "abdomen", "liver", "lung"};
}

SegmentationOptions SegmentationPreset(const std::string& name) {
  if (name == "phantom") return PhantomPreset();
  if (name == "cardiac-contrast") return CardiacContrastPreset();
  if (name == "chest") return ChestPreset();
  if (name == "abdomen") return AbdomenPreset();
  if (name == "liver") return LiverPreset();
  if (name == "lung") return LungPreset();
  throw Error(fmt::format("unknown segmentation preset '{}'", name), "segmentation options",
              fmt::format("use one of: {}", fmt::join(SegmentationPresetNames(), ", ")));
}

}  // namespace dg::stages::preop
