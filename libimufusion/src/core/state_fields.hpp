#pragma once
// The fields of the public value types a saved scan holds (StateArchive's free describe()): the
// scanner's configuration and the plain records of its state. Each lists every field of its
// type; a field added to one of these types must be added here, and any change to what a saved
// scan holds raises kVersion in scan/reconstructor_state.cpp (older files then fail to load with
// the version named, rather than be misread).

#include "core/drift_model.hpp"
#include "core/state_archive.hpp"
#include "imufusion/reconstructor.hpp"

namespace imufusion {

void describe(StateArchive& a, Intrinsics& x);
void describe(StateArchive& a, PreprocessConfig& x);
void describe(StateArchive& a, NormalGate& x);
void describe(StateArchive& a, IcpReliabilityThresholds& x);
void describe(StateArchive& a, DepthNoiseModel& x);
void describe(StateArchive& a, IcpConfig& x);
void describe(StateArchive& a, VolumeConfig& x);
void describe(StateArchive& a, TrackingConfig& x);
void describe(StateArchive& a, InertialConfig& x);
void describe(StateArchive& a, ImuAidConfig& x);
void describe(StateArchive& a, RelocalizationConfig& x);
void describe(StateArchive& a, RecoveryConfig& x);
void describe(StateArchive& a, LossSmoothingConfig& x);
/// Every field but `device` (the device is chosen where the scan is loaded).
void describe(StateArchive& a, ReconstructorConfig& x);

void describe(StateArchive& a, ImuSample& x);
void describe(StateArchive& a, StampedPose& x);
void describe(StateArchive& a, DriftPrior& x);
/// The layout of a depth image (size, format, scale); not its data.
void describe(StateArchive& a, DepthView& x);

}  // namespace imufusion
