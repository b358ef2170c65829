#pragma once

#include <optional>
#include <string>

#include "io/ct/dicom_writer.h"
#include "io/ct/displacement_field.h"
#include "io/metaimage.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// The DICOM description of phase `phase` of a generated 4D CT of `phases`:
// one study whose UIDs and frame of reference derive from `identity` (what
// makes that CT differ from any other), a series per phase with
// TemporalPositionIdentifier phase + 1 of phases, the cycle fraction phase /
// phases (NominalPercentageOfCardiacPhase), "phase NN (P%)" as its
// description and a fixed date, so the same identity writes the same bytes;
// with a heart rate, HeartRate and the matching TriggerTime. Patient and
// study description are the caller's.
io::DicomSeriesInfo PhaseSeriesInfo(const std::string& identity, int phase, int phases,
                                    std::optional<double> heart_rate_bpm);

// Writes phase `phase` of the phantom's 4D CT as a DICOM CT series into
// `folder`: one study for all phases (its UIDs and the frame of reference
// derived from the spec, so the same spec writes the same bytes), a series
// per phase with TemporalPositionIdentifier phase + 1 of spec.phases,
// NominalPercentageOfCardiacPhase 100 phase / phases, the matching TriggerTime
// and HeartRate, and "phase NN (P%)" as its description. The frame is the
// MetaImage's: ImagePositionPatient is the grid's origin plus k slices.
void WriteDicomPhase(const io::VolumeI16& volume, const PhantomSpec& spec, int phase, const std::string& folder);

// The exact displacement from the first phase's configuration to `phase`'s
// on the CT grid, in millimetres: u(X) = x(X) - X with x the motion's map from
// the first phase to this one, Deform(Undeform(X, first), phase). The motion
// is an analytic map of all of space (zero under the mount plane), so the field
// is that map everywhere, in the air as in the tissue: the map the CT's
// voxels were drawn through. Parallel over slices; deterministic.
io::DisplacementField PhaseDisplacementField(const io::VolumeI16& grid, const HeartMotion& motion,
                                             const MotionState& first, const MotionState& phase);

}  // namespace dg::tools::phantom
