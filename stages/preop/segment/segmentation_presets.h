#pragma once

#include <string>
#include <vector>

#include "stages/preop/segment/segmentation.h"

namespace dg::stages::preop {

// Automatic segmentation's settings for common scans, each a full
// SegmentationOptions (its `preset` member names it). The phantom's are the
// defaults; the real scans' have no mount (a patient rests on no rigid body
// that moves with the organ) and no markers, and give their ball radii in mm,
// so they suit any voxel size. HU ranges are from the literature cited at
// each preset (segmentation_presets.cc). On a real scan give a seed point
// inside the organ (and a region of interest to save time and memory): soft
// tissues share their CT numbers, so the largest component of a range is
// seldom the organ.
//
//  "phantom"          the phantom's materials (SegmentationOptions' defaults)
//  "cardiac-contrast" contrast-enhanced heart: myocardium and contrast blood,
//                     the blood pools (chambers, great vessels) internal
//  "chest"            non-contrast chest: the heart as soft tissue, no
//                     internal structures (blood and myocardium differ by
//                     less than noise without contrast)
//  "abdomen"          non-contrast abdomen: liver, spleen, kidneys as soft
//                     tissue, no internal structures
//  "liver"            liver at the portal venous phase, its contrast-filled
//                     vessels internal
//  "lung"             lung parenchyma; airways and vessels are holes, filled
SegmentationOptions PhantomPreset();
SegmentationOptions CardiacContrastPreset();
SegmentationOptions ChestPreset();
SegmentationOptions AbdomenPreset();
SegmentationOptions LiverPreset();
SegmentationOptions LungPreset();

// The preset of that name (above).
// @throws dg::Error for an unknown name, listing the names there are.
SegmentationOptions SegmentationPreset(const std::string& name);
std::vector<std::string> SegmentationPresetNames();

}  // namespace dg::stages::preop
