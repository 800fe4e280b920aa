#pragma once

// DBAT's camera XML (Börlin & Grussenmeyer, Damped Bundle Adjustment Toolbox 0.9: the
// `<cameras>` of a project script, or the camera file it writes after a calibration):
//   <document dbat_camera_version="1.0"><cameras><camera>
//     <unit>mm</unit> <sensor>7.253,5.43764</sensor> (or "auto,5.43764")
//     <image>2272,1704</image> <aspect>0.99961</aspect> <focal>7.5</focal> <model>3</model>
//     <cc>7.457</cc> <pp>3.615,2.613</pp> <skew>0</skew> <K>K1,K2,K3</K> <P>P1,P2</P>
//   </camera></cameras></document>
// read as a PHOTOGRAMMETRIC camera (sensors/photogrammetric_model.h):
//   b1 = 1 − aspect (DBAT writes aspect = 1 − as), b2 = skew,
//   pixel pitch: format height / image height on both axes, DBAT's square nominal pixel,
//   so that DBAT's estimated format width is W · pitch · (1 + b1) (its bundle's ssSize);
//   "auto" sensor width = aspect · height · W / H (DBAT parsedbatxmlcamstruct.m);
//   cc "focal" or absent = the nominal focal length; pp "default" or absent = format centre.
// Only DBAT's lens distortion models 2 (no affinity) and 3 (affinity before the lens
// correction) are this model; 1 (legacy), 4, 5 and the forward models are refused.

#include <string>

#include "mmba/sensors/camera.h"

namespace mmba::io {

/// The single camera of a DBAT camera XML file. InputError naming the file, the line, the
/// element and its text on a malformed file, an unknown element, a unit other than mm, a
/// model other than 2 or 3, more than 3 K or 2 P coefficients, or more than one camera.
sensors::Camera ReadDbatCamera(const std::string& path);

}  // namespace mmba::io
