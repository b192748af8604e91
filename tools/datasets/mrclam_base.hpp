// MRCLAM through the base station's own Fusion (basestation/fusion.hpp). Each robot's
// commanded velocity becomes the OdometryIncrements, and each camera image the
// FeatureObservations, that a robot would send; the base then associates by JCBB, relocates
// robots that join, gates new features and confirms or prunes tentative landmarks exactly as
// it does live. The landmarks' barcodes are not passed on (the base works without them);
// robots keep their ids, as their markers give them. What is scored is what ships.
#pragma once

#include "basestation/fusion.hpp"
#include "tools/datasets/mrclam.hpp"

namespace cairn::ccml {

/// Cooperative CML by the base's Fusion with `rules` (its defaults: the base's). The fleet is
/// set here: with robot ground truth every robot is known at its first sample (σ from
/// `options`); without, robot 1 defines the map frame at the origin and the others join by
/// relocation. Uses the noise model, duration, score_from and iterations of `options`.
/// Landmarks are matched to ground truth without labels (label-free fit, then the nearest
/// feature per landmark), so association errors are not known.
MrclamResult run_mrclam_base(const MrclamData& data, const MrclamOptions& options, base::FusionConfig rules = {});

}  // namespace cairn::ccml
